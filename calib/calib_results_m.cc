#include "calib/calib_results_m.h"

#include <cctype>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <map>
#include <sstream>

#include "base/checked_number.h"
#include "calib/calib_io.h"

namespace mm {
namespace {

struct Value {
  std::vector<double> numbers;
  int line = 0;
};

[[noreturn]] void Fail(const std::string& source, int line, const std::string& field,
                       const std::string& what) {
  std::string msg = source;
  if (line > 0) msg += ":" + std::to_string(line);
  msg += ": field '" + field + "': " + what;
  throw CalibrationError(msg);
}

bool IsNameStart(char c) { return std::isalpha(static_cast<unsigned char>(c)) || c == '_'; }
bool IsNameChar(char c) { return std::isalnum(static_cast<unsigned char>(c)) || c == '_'; }

// Parses one number token as Matlab prints it (also NaN/Inf, leading '+', e+000 exponents).
bool ParseNumber(std::string_view token, double* out) {
  if (!token.empty() && token.front() == '+') token.remove_prefix(1);
  if (token.empty()) return false;
  const auto [end, ec] = std::from_chars(token.data(), token.data() + token.size(), *out);
  return ec == std::errc() && end == token.data() + token.size();
}

// Splits the script into assignments. Statements end with ';' or a line end (outside brackets);
// `%` comments run to the line end. Statements that are not `name = number|vector` (strings,
// function calls) are skipped, since the toolbox's files hold none we need.
std::map<std::string, Value> Tokenize(const std::string& text, const std::string& source) {
  std::map<std::string, Value> vars;
  size_t i = 0;
  int line = 1;
  const size_t n = text.size();
  auto skip_blank = [&]() {
    while (i < n && (text[i] == ' ' || text[i] == '\t' || text[i] == '\r')) ++i;
  };
  auto skip_to_line_end = [&]() {
    while (i < n && text[i] != '\n') ++i;
  };
  while (i < n) {
    skip_blank();
    if (i >= n) break;
    const char c = text[i];
    if (c == '\n') {
      ++line;
      ++i;
      continue;
    }
    if (c == '%' || c == ';' || c == ',') {
      if (c == '%')
        skip_to_line_end();
      else
        ++i;
      continue;
    }
    if (!IsNameStart(c)) {  // Not an assignment: skip the statement.
      skip_to_line_end();
      continue;
    }
    const size_t name_begin = i;
    while (i < n && IsNameChar(text[i])) ++i;
    const std::string name = text.substr(name_begin, i - name_begin);
    const int name_line = line;
    skip_blank();
    if (i >= n || text[i] != '=' || (i + 1 < n && text[i + 1] == '=')) {
      skip_to_line_end();
      continue;
    }
    ++i;
    skip_blank();
    Value value;
    value.line = name_line;
    auto read_token = [&]() {
      const size_t b = i;
      while (i < n && !std::isspace(static_cast<unsigned char>(text[i])) && text[i] != ';' &&
             text[i] != ',' && text[i] != ']' && text[i] != '[' && text[i] != '%') {
        ++i;
      }
      return std::string_view(text).substr(b, i - b);
    };
    if (i < n && text[i] == '[') {
      ++i;
      bool closed = false;
      while (i < n) {
        const char d = text[i];
        if (d == ']') {
          ++i;
          closed = true;
          break;
        }
        if (d == '\n') {
          ++line;
          ++i;
        } else if (d == ' ' || d == '\t' || d == '\r' || d == ';' || d == ',') {
          ++i;
        } else if (d == '%') {
          skip_to_line_end();
        } else if (d == '.' && text.compare(i, 3, "...") == 0) {
          skip_to_line_end();  // Matlab line continuation.
        } else {
          const std::string_view token = read_token();
          double v = 0;
          if (token.empty() || !ParseNumber(token, &v)) {
            Fail(source, line, name,
                 "'" + std::string(token.empty() ? "[" : token) + "' is not a number");
          }
          value.numbers.push_back(v);
        }
      }
      if (!closed) Fail(source, name_line, name, "vector has no closing ']'");
    } else {
      const std::string_view token = read_token();
      double v = 0;
      if (token.empty() || !ParseNumber(token, &v)) {
        // A string, expression or call: not a value we read.
        skip_to_line_end();
        continue;
      }
      value.numbers.push_back(v);
    }
    vars[name] = std::move(value);
  }
  return vars;
}

class Reader {
 public:
  Reader(const std::map<std::string, Value>& vars, const std::string& source)
      : vars_(vars), source_(source) {}

  const Value* Find(const std::string& name) const {
    const auto it = vars_.find(name);
    return it == vars_.end() ? nullptr : &it->second;
  }

  // A vector of one of the allowed lengths; nullopt when absent and not required.
  std::optional<std::vector<double>> Vector(const std::string& name,
                                            std::initializer_list<size_t> lengths,
                                            bool required) const {
    const Value* v = Find(name);
    if (v == nullptr) {
      if (required) Fail(source_, 0, name, "missing");
      return std::nullopt;
    }
    std::string allowed;
    for (size_t len : lengths) {
      if (v->numbers.size() == len) return v->numbers;
      allowed += (allowed.empty() ? "" : " or ") + std::to_string(len);
    }
    Fail(source_, v->line, name,
         "expected " + allowed + " values, got " + std::to_string(v->numbers.size()));
  }

  std::optional<double> Scalar(const std::string& name, bool required) const {
    const auto v = Vector(name, {1}, required);
    if (!v) return std::nullopt;
    return (*v)[0];
  }

  // An integer in [lo, hi].
  std::optional<int> Int(const std::string& name, int lo, int hi, bool required) const {
    const auto v = Scalar(name, required);
    if (!v) return std::nullopt;
    std::string problem;
    const std::optional<int> i = CheckedNumber<int>(*v, {lo, hi}, &problem);
    if (!i) Fail(source_, Find(name)->line, name, problem);
    return i;
  }

  int Line(const std::string& name) const {
    const Value* v = Find(name);
    return v ? v->line : 0;
  }

 private:
  const std::map<std::string, Value>& vars_;
  const std::string& source_;
};

// Shortest text that reads back to the same double (std::to_chars), Matlab spelling for NaN/Inf.
std::string MatlabNumber(double v) {
  if (std::isnan(v)) return "NaN";
  if (std::isinf(v)) return v > 0 ? "Inf" : "-Inf";
  char buf[64];
  const auto [end, ec] = std::to_chars(buf, buf + sizeof(buf), v);
  return ec == std::errc() ? std::string(buf, end) : std::string("NaN");
}

std::string Vec(std::initializer_list<double> values) {
  std::string s = "[ ";
  bool first = true;
  for (double v : values) {
    if (!first) s += " ; ";
    s += MatlabNumber(v);
    first = false;
  }
  return s + " ]";
}

std::string Vec3(const Eigen::Vector3d& v) { return Vec({v.x(), v.y(), v.z()}); }

}  // namespace

bool LooksLikeCalibResultsM(const std::string& text) {
  std::istringstream in(text);
  std::string line;
  while (std::getline(in, line)) {
    const size_t b = line.find_first_not_of(" \t\r");
    if (b == std::string::npos) continue;
    if (line[b] == '%') return true;
    if (line[b] == '[' || line[b] == '#') return false;  // TOML table or comment.
    if (line.compare(b, 2, "fc") == 0 && line.find('[') != std::string::npos &&
        line.find(';') != std::string::npos) {
      return true;
    }
  }
  return false;
}

CalibResults ParseCalibResultsM(const std::string& text, const std::string& source_name) {
  const auto vars = Tokenize(text, source_name);
  const Reader r(vars, source_name);
  CalibResults out;
  BouguetCamera& cam = out.camera;

  const auto fc = *r.Vector("fc", {2}, true);
  const auto cc = *r.Vector("cc", {2}, true);
  const auto kc = *r.Vector("kc", {1, 2, 4, 5}, true);
  cam.fc = {fc[0], fc[1]};
  cam.cc = {cc[0], cc[1]};
  cam.kc = KcFromValues(kc);
  cam.alpha_c = r.Scalar("alpha_c", false).value_or(0.0);
  cam.width = *r.Int("nx", 1, kMaxImageSide, true);
  cam.height = *r.Int("ny", 1, kMaxImageSide, true);

  if (r.Find("fc_error") || r.Find("cc_error") || r.Find("kc_error")) {
    BouguetCamera::Uncertainty e;
    const auto efc = *r.Vector("fc_error", {2}, true);
    const auto ecc = *r.Vector("cc_error", {2}, true);
    const auto ekc = *r.Vector("kc_error", {1, 2, 4, 5}, true);
    e.fc = {efc[0], efc[1]};
    e.cc = {ecc[0], ecc[1]};
    e.kc = KcFromValues(ekc);
    e.alpha_c = r.Scalar("alpha_c_error", false).value_or(0.0);
    cam.error = e;
  }

  if (const std::string problem = cam.Check(); !problem.empty()) {
    const std::string field = problem.substr(0, problem.find(':'));
    Fail(source_name, r.Line(field), field, problem.substr(problem.find(':') + 2));
  }

  out.n_ima = r.Int("n_ima", 0, 100000, false).value_or(0);
  if (r.Find("est_dist") || r.Find("est_alpha") || r.Find("center_optim")) {
    CalibEstimationFlags f;
    if (const auto v = r.Vector("est_fc", {2}, false)) {
      f.est_fc = {(*v)[0] != 0 ? 1 : 0, (*v)[1] != 0 ? 1 : 0};
    }
    f.est_aspect_ratio = r.Int("est_aspect_ratio", 0, 1, false).value_or(1);
    f.center_optim = r.Int("center_optim", 0, 1, false).value_or(1);
    f.est_alpha = r.Int("est_alpha", 0, 1, false).value_or(0);
    if (const auto v = r.Vector("est_dist", {4, 5}, false)) {
      for (size_t i = 0; i < 5; ++i) f.est_dist[i] = i < v->size() && (*v)[i] != 0 ? 1 : 0;
    }
    out.flags = f;
  }

  out.images.resize(static_cast<size_t>(out.n_ima));
  for (int k = 1; k <= out.n_ima; ++k) {
    CalibImagePose& pose = out.images[static_cast<size_t>(k - 1)];
    const std::string s = std::to_string(k);
    const auto omc = r.Vector("omc_" + s, {3}, false);
    const auto tc = r.Vector("Tc_" + s, {3}, false);
    if (omc) pose.omc = {(*omc)[0], (*omc)[1], (*omc)[2]};
    if (tc) pose.tc = {(*tc)[0], (*tc)[1], (*tc)[2]};
    if (const auto e = r.Vector("omc_error_" + s, {3}, false)) {
      pose.omc_error = Eigen::Vector3d((*e)[0], (*e)[1], (*e)[2]);
    }
    if (const auto e = r.Vector("Tc_error_" + s, {3}, false)) {
      pose.tc_error = Eigen::Vector3d((*e)[0], (*e)[1], (*e)[2]);
    }
    pose.active = omc && tc && pose.omc.allFinite() && pose.tc.allFinite();
  }
  return out;
}

std::string FormatCalibResultsM(const CalibResults& res) {
  const BouguetCamera& c = res.camera;
  std::ostringstream o;
  o << "% Intrinsic and Extrinsic Camera Parameters\n"
       "%\n"
       "% This script file can be directly executed under Matlab to recover the camera intrinsic "
       "and extrinsic parameters.\n"
       "% IMPORTANT: This file contains neither the structure of the calibration objects nor the "
       "image coordinates of the calibration points.\n"
       "%            All those complementary variables are saved in the complete matlab data "
       "file Calib_Results.mat.\n"
       "% For more information regarding the calibration model visit "
       "http://www.vision.caltech.edu/bouguetj/calib_doc/\n"
       "% Written by monomesh (the toolbox's layout).\n\n\n";
  o << "%-- Focal length:\nfc = " << Vec({c.fc.x(), c.fc.y()}) << ";\n\n";
  o << "%-- Principal point:\ncc = " << Vec({c.cc.x(), c.cc.y()}) << ";\n\n";
  o << "%-- Skew coefficient:\nalpha_c = " << MatlabNumber(c.alpha_c) << ";\n\n";
  o << "%-- Distortion coefficients:\nkc = " << Vec({c.kc[0], c.kc[1], c.kc[2], c.kc[3], c.kc[4]})
    << ";\n\n";
  if (c.error) {  // The toolbox always writes them; a hand-made file may not have them.
    const BouguetCamera::Uncertainty& e = *c.error;
    o << "%-- Focal length uncertainty:\nfc_error = " << Vec({e.fc.x(), e.fc.y()}) << ";\n\n";
    o << "%-- Principal point uncertainty:\ncc_error = " << Vec({e.cc.x(), e.cc.y()}) << ";\n\n";
    o << "%-- Skew coefficient uncertainty:\nalpha_c_error = " << MatlabNumber(e.alpha_c)
      << ";\n\n";
    o << "%-- Distortion coefficients uncertainty:\nkc_error = "
      << Vec({e.kc[0], e.kc[1], e.kc[2], e.kc[3], e.kc[4]}) << ";\n\n";
  }
  o << "%-- Image size:\nnx = " << c.width << ";\nny = " << c.height << ";\n\n\n";
  if (res.flags) {
    const CalibEstimationFlags& f = *res.flags;
    o << "%-- Various other variables (may be ignored if you do not use the Matlab Calibration "
         "Toolbox):\n"
         "%-- Those variables are used to control which intrinsic parameters should be "
         "optimized\n\n";
    o << "n_ima = " << res.n_ima << ";\t\t\t\t\t\t% Number of calibration images\n";
    o << "est_fc = [ " << f.est_fc[0] << " ; " << f.est_fc[1]
      << " ];\t\t\t\t\t% Estimation indicator of the two focal variables\n";
    o << "est_aspect_ratio = " << f.est_aspect_ratio
      << ";\t\t\t\t% Estimation indicator of the aspect ratio fc(2)/fc(1)\n";
    o << "center_optim = " << f.center_optim
      << ";\t\t\t\t\t% Estimation indicator of the principal point\n";
    o << "est_alpha = " << f.est_alpha
      << ";\t\t\t\t\t\t% Estimation indicator of the skew coefficient\n";
    o << "est_dist = [ " << f.est_dist[0] << " ; " << f.est_dist[1] << " ; " << f.est_dist[2]
      << " ; " << f.est_dist[3] << " ; " << f.est_dist[4]
      << " ];\t% Estimation indicator of the distortion coefficients\n\n\n";
  } else if (res.n_ima > 0) {
    o << "n_ima = " << res.n_ima << ";\t\t\t\t\t\t% Number of calibration images\n\n\n";
  }
  if (!res.images.empty()) {
    o << "%-- Extrinsic parameters:\n"
         "%-- The rotation (omc_kk) and the translation (Tc_kk) vectors for every calibration "
         "image and their uncertainties\n\n";
    const Eigen::Vector3d nan3 = Eigen::Vector3d::Constant(std::nan(""));
    for (size_t k = 0; k < res.images.size(); ++k) {
      const CalibImagePose& p = res.images[k];
      const std::string s = std::to_string(k + 1);
      o << "%-- Image #" << s << ":\n";
      o << "omc_" << s << " = " << Vec3(p.active ? p.omc : nan3) << ";\n";
      o << "Tc_" << s << "  = " << Vec3(p.active ? p.tc : nan3) << ";\n";
      if (p.omc_error) o << "omc_error_" << s << " = " << Vec3(*p.omc_error) << ";\n";
      if (p.tc_error) o << "Tc_error_" << s << "  = " << Vec3(*p.tc_error) << ";\n";
      o << "\n";
    }
  }
  return o.str();
}

}  // namespace mm
