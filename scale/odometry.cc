#include "scale/odometry.h"

#include <algorithm>
#include <array>
#include <charconv>
#include <cmath>
#include <cstdio>

namespace mm {
namespace {

// The next whitespace-separated token of `rest` (empty at the end).
std::string_view NextToken(std::string_view* rest) {
  const size_t begin = rest->find_first_not_of(" \t\r\n");
  if (begin == std::string_view::npos) {
    *rest = {};
    return {};
  }
  const size_t end = rest->find_first_of(" \t\r\n", begin);
  const std::string_view token =
      rest->substr(begin, end == std::string_view::npos ? rest->size() - begin : end - begin);
  *rest = end == std::string_view::npos ? std::string_view{} : rest->substr(end);
  return token;
}

bool ParseFinite(std::string_view token, double* value) {
  if (token.empty()) return false;
  const char* first = token.data();
  if (*first == '+') ++first;  // from_chars does not take a leading '+'.
  const auto [ptr, ec] = std::from_chars(first, token.data() + token.size(), *value);
  return ec == std::errc() && ptr == token.data() + token.size() && std::isfinite(*value);
}

std::string Seconds(double s) {
  char buf[32];
  std::snprintf(buf, sizeof(buf), "%.3f", s);
  return buf;
}

}  // namespace

std::optional<OdometrySample> ParseOdometryLine(std::string_view line, std::string* error) {
  static constexpr std::array<const char*, 8> kFields = {"T",  "X",  "Y",  "Z",
                                                         "QX", "QY", "QZ", "QW"};
  std::array<double, 8> v{};
  size_t n = 0;
  std::string_view rest = line;
  for (std::string_view token = NextToken(&rest); !token.empty(); token = NextToken(&rest)) {
    if (n == v.size()) {
      *error = "odometry: more than 8 numbers (T X Y Z [QX QY QZ QW])";
      return std::nullopt;
    }
    if (!ParseFinite(token, &v[n])) {
      *error = std::string("odometry: ") + kFields[n] + " is not a finite number";
      return std::nullopt;
    }
    ++n;
  }
  if (n != 4 && n != 8) {
    *error = n < 4 ? std::string("odometry: ") + kFields[n] + " is missing (T X Y Z [QX QY QZ QW])"
                   : "odometry: the quaternion needs all of QX QY QZ QW";
    return std::nullopt;
  }
  OdometrySample sample;
  sample.time_s = v[0];
  sample.position_m = Eigen::Vector3d(v[1], v[2], v[3]);
  if (n == 8) {
    Eigen::Quaterniond q(v[7], v[4], v[5], v[6]);
    const double norm = q.norm();
    if (!(norm > 1e-9) || !std::isfinite(norm)) {
      *error = "odometry: the quaternion has zero norm";
      return std::nullopt;
    }
    q.coeffs() /= norm;
    sample.orientation = q;
  }
  return sample;
}

void OdometryTrack::Add(const OdometrySample& sample) {
  const auto it = std::lower_bound(samples_.begin(), samples_.end(), sample.time_s,
                                   [](const OdometrySample& s, double t) { return s.time_s < t; });
  if (it != samples_.end() && it->time_s == sample.time_s) {
    *it = sample;
  } else {
    samples_.insert(it, sample);
  }
  while (samples_.size() > capacity_) samples_.pop_front();
}

std::optional<Eigen::Vector3d> OdometryTrack::PositionAt(double time_s,
                                                         const OdometryLookupOptions& options,
                                                         std::string* why_not) const {
  if (samples_.empty()) {
    *why_not = "no odometry received";
    return std::nullopt;
  }
  if (time_s <= samples_.front().time_s || time_s >= samples_.back().time_s) {
    const OdometrySample& nearest =
        time_s <= samples_.front().time_s ? samples_.front() : samples_.back();
    const double age = std::abs(time_s - nearest.time_s);
    if (age > options.max_age_s) {
      *why_not = "the nearest odometry is " + Seconds(age) +
                 " s from the keyframe (max_odom_age_s " + Seconds(options.max_age_s) + ")";
      return std::nullopt;
    }
    return nearest.position_m;
  }
  const auto after =
      std::lower_bound(samples_.begin(), samples_.end(), time_s,
                       [](const OdometrySample& s, double t) { return s.time_s < t; });
  const auto before = std::prev(after);
  const double gap = after->time_s - before->time_s;
  if (gap > options.max_gap_s) {
    *why_not = "gap of " + Seconds(gap) + " s in the odometry around the keyframe";
    return std::nullopt;
  }
  const double w = (time_s - before->time_s) / gap;
  return (1.0 - w) * before->position_m + w * after->position_m;
}

}  // namespace mm
