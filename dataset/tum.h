#pragma once
// TUM RGB-D dataset files (Sturm et al., IROS 2012): image lists (`timestamp path`) and
// ground-truth trajectories (`timestamp tx ty tz qx qy qz qw`, camera-to-world, Hamilton).
//
// Thread-safety: pure functions and immutable values; reentrant.

#include <Eigen/Geometry>
#include <filesystem>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

namespace mm {

/// Thrown when a dataset file cannot be read; the message names the file and line.
class DatasetError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// One line of a TUM image list.
struct TumFrame {
  double timestamp_s = 0.0;    ///< Dataset time, seconds.
  std::filesystem::path path;  ///< Absolute (resolved against the list's folder).
  int line = 0;                ///< Line in the list, for messages.
};

/// Reads a TUM image list (rgb.txt, depth.txt or any `timestamp path` file). Comment lines
/// start with '#'. Relative paths are resolved against the list's folder.
/// \throws DatasetError naming file and line on a malformed line or an unreadable file.
std::vector<TumFrame> ReadTumList(const std::filesystem::path& list_file);

/// ReadTumList on text; relative paths resolve against `folder`, messages name `source_name`.
std::vector<TumFrame> ParseTumList(const std::string& text, const std::filesystem::path& folder,
                                   const std::string& source_name);

/// Empty when the frames' timestamps never decrease and no two neighbours are more than
/// `max_gap_s` apart, else a message naming the list, the line and the timestamp.
[[nodiscard]] std::string CheckTimeOrder(const std::vector<TumFrame>& frames, double max_gap_s,
                                         const std::string& list_name);

/// Index of the frame nearest in time to `timestamp_s`, or -1 when none is within `max_dt_s`
/// (ties: the later).
[[nodiscard]] int NearestFrame(const std::vector<TumFrame>& frames, double timestamp_s,
                               double max_dt_s);

/// A rigid transform world_from_cam (TUM convention) at a time.
struct TimedPose {
  double timestamp_s = 0.0;
  Eigen::Isometry3d world_from_cam = Eigen::Isometry3d::Identity();
};

/// A ground-truth trajectory, sorted by time, with interpolation.
class Trajectory {
 public:
  /// \throws DatasetError naming file and line.
  static Trajectory Read(const std::filesystem::path& groundtruth_file);
  /// Read on text; messages name `source_name`.
  static Trajectory Parse(const std::string& text, const std::string& source_name);
  explicit Trajectory(std::vector<TimedPose> poses);

  /// Linear position / SLERP rotation between the bracketing samples. Outside the sampled
  /// range the nearest sample is returned if it is within `max_extrapolation_s`; otherwise
  /// nullopt.
  [[nodiscard]] std::optional<Eigen::Isometry3d> WorldFromCamAt(
      double timestamp_s, double max_extrapolation_s = 0.1) const;

  [[nodiscard]] const std::vector<TimedPose>& poses() const { return poses_; }

 private:
  std::vector<TimedPose> poses_;
};

/// A TUM folder read for an evaluation: its image list, depth.txt when there is one, and
/// groundtruth.txt.
struct TumSequence {
  std::vector<TumFrame> frames;
  std::vector<TumFrame> depth_frames;  ///< Empty without depth.txt.
  Trajectory trajectory{{}};
};

/// Reads `folder`'s image list (`list`; empty: rgb.txt; a relative path that does not exist
/// from the working directory is taken relative to `folder`), its depth.txt when present and
/// its groundtruth.txt.
/// \throws DatasetError naming file and line.
TumSequence ReadTumSequence(const std::filesystem::path& folder, const std::filesystem::path& list);

/// Relative pose of a pair: cam_b_from_cam_a = inv(world_from_b) * world_from_a.
Eigen::Isometry3d CamBFromCamA(const Eigen::Isometry3d& world_from_a,
                               const Eigen::Isometry3d& world_from_b);

/// Angle of the rotation R_est^T R_gt, degrees.
double RotationErrorDeg(const Eigen::Matrix3d& r_est, const Eigen::Matrix3d& r_gt);

/// Angle between two translation directions, degrees (0 when either is zero).
double DirectionErrorDeg(const Eigen::Vector3d& t_est, const Eigen::Vector3d& t_gt);

}  // namespace mm
