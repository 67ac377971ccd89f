#pragma once
// The robot's odometry as a scale source: timestamped positions of the camera's carrier in a
// metric frame (the robot's odom frame), as a bridge writes them to the control socket, and
// their value at a keyframe's capture time by linear interpolation between the neighbouring
// samples. Only positions matter for the scale (|c_B - c_A| in metres); the orientation is kept
// for the walk.
//
// Thread-safety: OdometryTrack is thread-bound; ParseOdometryLine is pure.

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstddef>
#include <deque>
#include <optional>
#include <string>
#include <string_view>

namespace mm {

struct OdometrySample {
  double time_s = 0.0;  ///< On the clock the keyframe times are given in.
  Eigen::Vector3d position_m = Eigen::Vector3d::Zero();
  std::optional<Eigen::Quaterniond> orientation;  ///< Unit quaternion when given.
};

/// One line of the odometry protocol: `T X Y Z [QX QY QZ QW]` (seconds, metres; the
/// quaternion normalised), numbers as C locale decimals. The `odom` command word is the
/// caller's. Returns the sample, or nullopt with `*error` naming the field that is missing,
/// not a finite number, or (for the quaternion) of zero norm.
std::optional<OdometrySample> ParseOdometryLine(std::string_view line, std::string* error);

struct OdometryLookupOptions {
  /// A time outside the samples' span is answered by the nearest sample when it is at most
  /// this far (seconds): the robot is taken as standing still since (or until) then.
  double max_age_s = 0.5;
  /// Two samples further apart than this do not bracket a time (a gap in the stream).
  double max_gap_s = 1.0;
};

/// A bounded, time-ordered buffer of odometry samples.
class OdometryTrack {
 public:
  explicit OdometryTrack(size_t capacity = 20000) : capacity_(capacity) {}

  /// Adds a sample (out-of-order samples are placed by time; one at the time of an existing
  /// sample replaces it); the oldest go beyond the capacity.
  void Add(const OdometrySample& sample);

  /// The position at `time_s`, or nullopt with `*why_not` ("no odometry", "odometry is 3.2 s
  /// older than the keyframe", "gap of 2.0 s in the odometry at ...").
  [[nodiscard]] std::optional<Eigen::Vector3d> PositionAt(double time_s,
                                                          const OdometryLookupOptions& options,
                                                          std::string* why_not) const;

  [[nodiscard]] size_t size() const { return samples_.size(); }
  [[nodiscard]] bool empty() const { return samples_.empty(); }
  [[nodiscard]] const OdometrySample& newest() const { return samples_.back(); }

 private:
  size_t capacity_;
  std::deque<OdometrySample> samples_;  // Ascending time.
};

}  // namespace mm
