#pragma once
// The keyframe gate: decides, frame by frame after keyframe A, when the camera has moved enough
// for a good two-view reconstruction. Corners of A (Shi-Tomasi) are tracked frame to frame with
// pyramidal Lucas-Kanade (Bouguet's KLT). On each frame a quick relative-pose fit on the tracks
// gives the rotation-compensated parallax: the angle between each track's ray in the current
// frame and its ray from A rotated by the estimated R (for a point at depth Z and baseline b this
// is the triangulation angle, ~b/Z), so rotation alone never counts as baseline. Keyframe B is
// taken once the median parallax passes the threshold with enough inliers and the essential
// model clearly beats a homography (which explains a pure rotation or a plane as well).
//
// Thread-safety: thread-bound (one gate per capture, fed by one thread).

#include <Eigen/Core>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

namespace mm {

struct KeyframeGateOptions {
  /// Take B when the median rotation-compensated parallax passes this. Measured: 0.33 deg on
  /// the bundled keyframe pair (0,1), whose median triangulation angle is 2.0 deg and which
  /// reconstructs within 0.2 deg of ground truth; <= 0.02 deg for pure rotation; <= 0.07 deg
  /// for 2 cm of translation at 1-2 m.
  double parallax_deg = 0.3;
  int max_corners = 400;       ///< Corners of A to track.
  double corner_quality = 0.01;  ///< Shi-Tomasi quality level (relative to the best corner).
  double min_corner_distance_px = 10.0;
  int min_tracks = 40;         ///< Fewer surviving tracks: the capture ends with "lost track".
  int min_inliers = 30;        ///< Inliers of the essential fit needed to take B.
  /// The essential model must explain the tracks clearly better than a homography: take B only
  /// when homography inliers < this share of essential inliers.
  double max_homography_inlier_ratio = 0.8;
  double ransac_threshold_px = 1.0;  ///< For both fits.
  int ransac_iterations = 200;       ///< Cap per fit (the gate runs every frame).
  int klt_window_px = 21;
  int klt_levels = 3;
  double max_klt_error = 20.0;        ///< Drop tracks whose KLT error exceeds this.
  double max_forward_backward_px = 1.0;  ///< Drop tracks that do not track back to themselves.
  [[nodiscard]] std::string Check() const;
};

/// What the gate saw on one frame.
struct GateDecision {
  enum class Verdict { kWait, kTakeB, kLostTrack };
  Verdict verdict = Verdict::kWait;
  int tracks = 0;                    ///< Tracks alive after this frame.
  int essential_inliers = 0;
  int homography_inliers = 0;
  /// Rotation-compensated parallax: the median angle between the tracks' rays and A's rays
  /// rotated by the best-fitting rotation (what no camera rotation can produce).
  double median_parallax_deg = 0.0;
  std::string reason;                ///< Why B was not taken (or why the track was lost).
};

class KeyframeGate {
 public:
  /// `K`: intrinsics of the (undistorted) frames.
  KeyframeGate(const Eigen::Matrix3d& K, KeyframeGateOptions options);

  /// Starts a capture on keyframe A (8-bit gray). Returns the number of corners found.
  int Start(const cv::Mat& gray_a);
  /// Tracks into the next frame (8-bit gray, same size) and decides.
  GateDecision Update(const cv::Mat& gray);

  [[nodiscard]] int tracks() const { return static_cast<int>(points_a_.size()); }

 private:
  Eigen::Matrix3d K_;
  Eigen::Matrix3d K_inv_;
  KeyframeGateOptions options_;
  cv::Mat previous_;                     // Last gray frame.
  std::vector<cv::Point2f> points_a_;    // Track origins in A.
  std::vector<cv::Point2f> points_prev_; // The same tracks in the previous frame.
};

}  // namespace mm
