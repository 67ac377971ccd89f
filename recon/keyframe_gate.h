#pragma once
// The keyframe gate: decides, frame by frame after keyframe A, when the camera has moved enough
// for a good two-view reconstruction. Corners of A (Shi-Tomasi) are tracked frame to frame with
// pyramidal Lucas-Kanade (Bouguet's KLT), forward-backward checked. On each frame the tracks go
// through the reconstruction's own acceptance test (ProbeTwoView, recon/two_view.h): F and H by
// RANSAC, the pair classification (no parallax / pure rotation / planar), E = K^T F K, the pose
// by cheirality and the median triangulation angle of the inliers. Keyframe B is taken when
// that test passes and the median angle reaches `parallax_deg`, so the gate never takes a B the
// reconstruction would refuse for the same reasons; rotation alone never counts as baseline.
//
// Thread-safety: thread-bound (one gate per capture, fed by one thread).

#include <Eigen/Core>
#include <algorithm>
#include <opencv2/core.hpp>
#include <span>
#include <string>
#include <vector>

#include "recon/two_view.h"

namespace mm {

struct KeyframeGateOptions {
  /// Take B when the median triangulation angle of the tracks' inliers under the gate's pose
  /// fit reaches this (degrees): the measure the reconstruction refuses a pair by
  /// (two_view.min_median_triangulation_angle_deg, which this must not be below). The margin
  /// over it covers the SIFT points' angles differing from the tracks' (docs/recon_tuning.md).
  double parallax_deg = 2.0;
  /// The reconstruction's tests and thresholds (F and H RANSAC thresholds, the classification,
  /// cheirality, the minimum median angle); the daemon copies its [recon] settings here.
  /// max_ransac_iterations is capped by `ransac_iterations` (the gate runs every frame).
  TwoViewOptions two_view;
  int max_corners = 400;       ///< Corners of A to track.
  double corner_quality = 0.01;  ///< Shi-Tomasi quality level (relative to the best corner).
  double min_corner_distance_px = 10.0;
  int min_tracks = 40;         ///< Fewer surviving tracks: the capture ends with "lost track".
  /// When fewer than this many tracks survive (the view is leaving A's, e.g. turning a
  /// corner), B is taken as soon as the reconstruction's own minimum angle is met, before the
  /// track is lost, instead of waiting for `parallax_deg`.
  int early_b_tracks = 100;
  int min_inliers = 30;              ///< F inliers among the tracks needed to take B.
  int ransac_iterations = 200;       ///< Cap per fit (the gate runs every frame).
  /// LM iterations of the tracks' F (the reconstruction refines its own F; the gate's
  /// decision does not need it, and it was most of the probe's time per frame).
  int f_refine_iterations = 0;
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
  int essential_inliers = 0;         ///< F inliers among the tracks.
  int homography_inliers = 0;
  /// Median triangulation angle of the inlier tracks under the gate's pose fit (degrees; 0
  /// when the probe stopped before the pose).
  double median_parallax_deg = 0.0;
  TwoViewFailure failure = TwoViewFailure::kNone;  ///< The probe's verdict on the tracks.
  std::string reason;                ///< Why B was not taken (or why the track was lost).
};

/// A frame the gate tracked through, with its tracks: where each started in A and where it
/// is in the frame (undistorted pixels, index-aligned).
struct GateWaypoint {
  cv::Mat gray;
  std::vector<cv::Point2f> origins_a;
  std::vector<cv::Point2f> positions;
  double parallax_deg = 0;  ///< The gate's median triangulation angle at it (0: none measured).
};

/// The corners of A the gate tracks (Shi-Tomasi with the options' count, quality, spacing).
std::vector<cv::Point2f> DetectGateCorners(const cv::Mat& gray_a,
                                           const KeyframeGateOptions& options);

/// One step of the gate's tracking: `points` (in `from`, 8-bit gray) into `to` (same size) by
/// pyramidal KLT; keeps the tracks, and their `origins_a` (index-aligned), that stay inside
/// `to`, within the KLT error and track back to where they started. Fewer than 8: none kept.
void TrackForwardBackward(const cv::Mat& from, const cv::Mat& to,
                          const KeyframeGateOptions& options, std::vector<cv::Point2f>* origins_a,
                          std::vector<cv::Point2f>* points);

/// Frames before keyframe A with A's corners tracked back to them, as source views before A
/// for the dense stage: A's corners (DetectGateCorners) are tracked frame to frame back
/// through `frames_before_a` (8-bit gray, A's size, newest first) as the gate tracks
/// forward. One waypoint per frame reached with at least options.min_tracks tracks (the
/// tracking stops at the first frame with fewer); parallax_deg is 0 (not measured).
std::vector<GateWaypoint> TrackBackFromA(const cv::Mat& gray_a,
                                         std::span<const cv::Mat> frames_before_a,
                                         const KeyframeGateOptions& options);

class KeyframeGate {
 public:
  /// `K`: intrinsics of the (undistorted) frames.
  KeyframeGate(const Eigen::Matrix3d& K, KeyframeGateOptions options);

  /// Starts a capture on keyframe A (8-bit gray). Returns the number of corners found.
  int Start(const cv::Mat& gray_a);
  /// Tracks into the next frame (8-bit gray, same size) and decides.
  GateDecision Update(const cv::Mat& gray);

  [[nodiscard]] int tracks() const { return static_cast<int>(points_a_.size()); }
  /// The surviving tracks: where each started in A and where it is in the last frame
  /// (undistorted pixels, index-aligned).
  [[nodiscard]] const std::vector<cv::Point2f>& track_origins_a() const { return points_a_; }
  [[nodiscard]] const std::vector<cv::Point2f>& track_positions() const { return points_prev_; }
  /// Of the frames before B, the one at which the tracks' angle was nearest half the required
  /// one: about halfway to B, a further view for the dense stage. Empty before the first Update.
  [[nodiscard]] const GateWaypoint& halfway() const { return halfway_; }

  /// Raises the angle the next B must reach (a later B after the reconstruction refused one);
  /// Start resets it to options.parallax_deg.
  void RequireParallax(double deg) { target_parallax_deg_ = std::max(deg, options_.parallax_deg); }
  [[nodiscard]] double required_parallax_deg() const { return target_parallax_deg_; }

 private:
  Eigen::Matrix3d K_;
  KeyframeGateOptions options_;
  double target_parallax_deg_ = 0.0;
  cv::Mat previous_;                     // Last gray frame.
  std::vector<cv::Point2f> points_a_;    // Track origins in A.
  std::vector<cv::Point2f> points_prev_; // The same tracks in the previous frame.
  GateWaypoint halfway_;
};

}  // namespace mm
