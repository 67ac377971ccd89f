#pragma once
// Sub-pixel refinement of the points' observations in keyframe B, after the pose is known.
//
// SIFT places a keypoint at a scale-space extremum: for the blobs of coarser octaves its
// position in each image is uncertain by a fraction of the blob's size, and the two
// observations of a 3-D point are localized independently. Pyramidal Lucas-Kanade (Bouguet,
// "Pyramidal implementation of the Lucas Kanade feature tracker", 2000; cv::calcOpticalFlowPyrLK)
// aligns a window around A's observation with B, starting at B's keypoint, so B's observation
// is measured against A's. Only a refinement that passes the forward-backward check (Kalal,
// Mikolajczyk, Matas, ICPR 2010: tracking back from B must return to A's position) and moves
// less than `max_shift_px` is taken. The points are then triangulated again under the pose
// from the bundle adjustment, which stays as it is: refined observations did not improve the
// pose on the TUM pairs (rotation 0.30 -> 0.31-0.35 deg), but they do improve the depths of
// short-baseline points (docs/recon_tuning.md).
//
// Thread-safety: pure functions; reentrant.

#include <Eigen/Core>
#include <opencv2/core.hpp>
#include <span>
#include <string>
#include <vector>

#include "recon/two_view.h"

namespace mm {

struct PointRefinementOptions {
  bool enabled = true;
  int window_px = 15;                    ///< Lucas-Kanade window (odd, >= 5).
  int pyramid_levels = 1;                ///< Coarser levels above the full image (0 = none).
  double max_shift_px = 2.0;             ///< A refinement moving B's keypoint further is dropped.
  double max_forward_backward_px = 0.1;  ///< Tracking B back must land this close to A.
  int max_iterations = 30;
  [[nodiscard]] std::string Check() const;
};

struct PointRefinementSummary {
  int points = 0;                ///< Points whose observation in B was tried.
  int refined = 0;               ///< Points triangulated again from a refined observation.
  double median_shift_px = 0.0;  ///< Median move of B's observation, over the refined ones.
};

/// Refines `pixels_b[i]`, the observation in B matching `pixels_a[i]` in A, by Lucas-Kanade
/// between the 8-bit gray images. Returns the positions in B: refined ones where the checks
/// passed, the given ones elsewhere. `accepted` (optional) receives one flag per position.
std::vector<Eigen::Vector2d> RefineObservationsLk(const cv::Mat& gray_a, const cv::Mat& gray_b,
                                                  std::span<const Eigen::Vector2d> pixels_a,
                                                  std::span<const Eigen::Vector2d> pixels_b,
                                                  const PointRefinementOptions& options,
                                                  std::vector<bool>* accepted = nullptr);

/// For a successful two-view result whose point j was observed at `point_pixels_a[j]` and
/// `point_pixels_b[j]`: refines the observations in B, triangulates each point again under
/// `result`'s pose (Gauss-Newton from the current point) and keeps the new point and
/// observation where it is in front of both cameras, within
/// `two_view.max_reprojection_error_after_ba_px` and above `two_view.min_triangulation_angle_deg`.
/// The result's reprojection RMS and median angle are updated.
PointRefinementSummary RefinePoints(const cv::Mat& gray_a, const cv::Mat& gray_b,
                                    const Eigen::Matrix3d& K, const TwoViewOptions& two_view,
                                    const PointRefinementOptions& options,
                                    std::span<const Eigen::Vector2d> point_pixels_a,
                                    std::vector<Eigen::Vector2d>* point_pixels_b,
                                    TwoViewResult* result);

}  // namespace mm
