#include "calib/calib_io.h"

#include <toml++/toml.h>

#include <cstdio>
#include <sstream>

#include "base/checked_number.h"
#include "base/text_file.h"
#include "calib/calib_results_m.h"

namespace mm {
namespace {

[[noreturn]] void Fail(const std::string& source, const toml::source_region* where,
                       const std::string& field, const std::string& what) {
  std::string msg = source;
  if (where != nullptr && where->begin.line > 0) msg += ":" + std::to_string(where->begin.line);
  msg += ": field '" + field + "': " + what;
  throw CalibrationError(msg);
}

// What each field may hold (base/checked_number.h): magnitudes far beyond any real camera
// but finite, so nothing absurd reaches the camera model or OpenCV's undistortion maps.
constexpr NumberRange<int> kImageSide{1, kMaxImageSide};
constexpr NumberRange<double> kPixels{-1e6, 1e6};       // fc, cc
constexpr NumberRange<double> kCoefficient{-1e6, 1e6};  // kc, alpha_c
constexpr NumberRange<double> kUncertainty{0.0, 1e6};   // [camera.error]

// Reads an array of numbers of one of the allowed lengths, each within `range`.
template <typename T>
std::vector<T> ReadNumbers(const toml::table& table, const std::string& source,
                           const std::string& prefix, const char* key,
                           std::initializer_list<size_t> lengths, NumberRange<T> range,
                           bool required) {
  const std::string field = prefix + key;
  const toml::node* node = table.get(key);
  if (node == nullptr) {
    if (required) Fail(source, &table.source(), field, "missing");
    return {};
  }
  const toml::array* arr = node->as_array();
  if (arr == nullptr) Fail(source, &node->source(), field, "expected an array of numbers");
  std::vector<T> values;
  for (const toml::node& element : *arr) {
    std::string problem;
    const std::optional<T> v = CheckedNumberOf<T>(element, range, &problem);
    if (!v) Fail(source, &element.source(), field, problem);
    values.push_back(*v);
  }
  bool ok = false;
  std::string allowed;
  for (size_t n : lengths) {
    ok = ok || values.size() == n;
    allowed += (allowed.empty() ? "" : " or ") + std::to_string(n);
  }
  if (!ok) {
    Fail(source, &node->source(), field,
         "expected " + allowed + " values, got " + std::to_string(values.size()));
  }
  return values;
}

double ReadNumber(const toml::table& table, const std::string& source, const std::string& prefix,
                  const char* key, NumberRange<double> range, double fallback) {
  const toml::node* node = table.get(key);
  if (node == nullptr) return fallback;
  std::string problem;
  const std::optional<double> v = CheckedNumberOf<double>(*node, range, &problem);
  if (!v) Fail(source, &node->source(), prefix + key, problem);
  return *v;
}

std::string TomlNumber(double v) {
  char buf[64];
  std::snprintf(buf, sizeof(buf), "%.17g", v);
  std::string s(buf);
  if (s.find_first_of(".eEn") == std::string::npos) s += ".0";
  return s;
}

}  // namespace

BouguetCamera ParseCalibrationToml(const std::string& text, const std::string& source_name) {
  toml::table root;
  try {
    root = toml::parse(text, source_name);
  } catch (const toml::parse_error& e) {
    throw CalibrationError(source_name + ":" + std::to_string(e.source().begin.line) +
                           ": not valid TOML: " + std::string(e.description()));
  }
  const toml::table* cam = root["camera"].as_table();
  if (cam == nullptr) Fail(source_name, nullptr, "camera", "missing [camera] table");

  BouguetCamera camera;
  const std::string p = "camera.";
  const auto size = ReadNumbers(*cam, source_name, p, "image_size", {2}, kImageSide, true);
  const auto fc = ReadNumbers(*cam, source_name, p, "fc", {2}, kPixels, true);
  const auto cc = ReadNumbers(*cam, source_name, p, "cc", {2}, kPixels, true);
  const auto kc = ReadNumbers(*cam, source_name, p, "kc", {4, 5}, kCoefficient, true);
  camera.width = size[0];
  camera.height = size[1];
  camera.fc = {fc[0], fc[1]};
  camera.cc = {cc[0], cc[1]};
  camera.kc = KcFromValues(kc);
  camera.alpha_c = ReadNumber(*cam, source_name, p, "alpha_c", kCoefficient, 0.0);

  if (const toml::table* err = (*cam)["error"].as_table()) {
    const std::string pe = p + "error.";
    BouguetCamera::Uncertainty u;
    const auto efc = ReadNumbers(*err, source_name, pe, "fc", {2}, kUncertainty, true);
    const auto ecc = ReadNumbers(*err, source_name, pe, "cc", {2}, kUncertainty, true);
    const auto ekc = ReadNumbers(*err, source_name, pe, "kc", {4, 5}, kUncertainty, true);
    u.fc = {efc[0], efc[1]};
    u.cc = {ecc[0], ecc[1]};
    u.kc = KcFromValues(ekc);
    u.alpha_c = ReadNumber(*err, source_name, pe, "alpha_c", kUncertainty, 0.0);
    camera.error = u;
  }

  if (const std::string problem = camera.Check(); !problem.empty()) {
    const std::string field = problem.substr(0, problem.find(':'));
    const toml::node* node = cam->get(field);
    Fail(source_name, node ? &node->source() : nullptr, p + field,
         problem.substr(problem.find(':') + 2));
  }
  return camera;
}

BouguetCamera LoadCalibration(const std::filesystem::path& path) {
  std::string error;
  const std::optional<std::string> text = ReadTextFile(path, kMaxDataFileBytes, &error);
  if (!text) throw CalibrationError(error);
  const std::string& content = *text;
  // Both formats load anywhere: Calib_Results.m by extension or content, else the TOML format.
  if (path.extension() == ".m" || LooksLikeCalibResultsM(content)) {
    return ParseCalibResultsM(content, path.string()).camera;
  }
  return ParseCalibrationToml(content, path.string());
}

std::string FormatCalibrationToml(const BouguetCamera& c) {
  std::ostringstream out;
  auto vec = [](std::initializer_list<double> v) {
    std::string s = "[";
    for (double x : v) s += (s.size() > 1 ? ", " : "") + TomlNumber(x);
    return s + "]";
  };
  out << "# monomesh calibration, Bouguet parameterization (see docs/calibration.md)\n"
      << "[camera]\n"
      << "image_size = [" << c.width << ", " << c.height << "]\n"
      << "fc = " << vec({c.fc.x(), c.fc.y()}) << "\n"
      << "cc = " << vec({c.cc.x(), c.cc.y()}) << "\n"
      << "alpha_c = " << TomlNumber(c.alpha_c) << "\n"
      << "kc = " << vec({c.kc[0], c.kc[1], c.kc[2], c.kc[3], c.kc[4]}) << "\n";
  if (c.error) {
    const auto& e = *c.error;
    out << "\n[camera.error]  # 3-sigma uncertainties\n"
        << "fc = " << vec({e.fc.x(), e.fc.y()}) << "\n"
        << "cc = " << vec({e.cc.x(), e.cc.y()}) << "\n"
        << "alpha_c = " << TomlNumber(e.alpha_c) << "\n"
        << "kc = " << vec({e.kc[0], e.kc[1], e.kc[2], e.kc[3], e.kc[4]}) << "\n";
  }
  return out.str();
}

}  // namespace mm
