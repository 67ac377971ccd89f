#pragma once
// The world's up direction in a camera's frame from the image's vertical lines: their vanishing
// point (the Manhattan-world cue of Coughlan & Yuille 1999; the segment-to-VP consistency
// measure of Tardif, ICCV 2009). Line segments from OpenCV's LSD (von Gioi et al., PAMI 2010)
// whose direction may be vertical within `max_deviation_deg` of the expected up vote; a RANSAC
// over pairs of segments proposes the direction, the segments consistent with it (the angle at
// their midpoint between the segment and the line to the vanishing point, within what a
// `endpoint_sigma_px` error of their endpoints explains) are its inliers, and the direction is
// refitted to them by weighted least squares (the smallest eigenvector of the sum of their
// interpretation planes' normals' outer products, weighted by length).
//
// A level camera sees vertical lines as nearly parallel: its pitch is only in their slight
// convergence. Where the image also shows a dominant horizontal direction ahead (a corridor's
// floor, ceiling and door lines converging), up is taken perpendicular to it (Manhattan world):
// that vanishing point lies near the image centre and moves f tan(1 deg) pixels per degree of
// pitch.
// Where a floor strip fixes the floor plane's pitch poorly (docs/scale.md), this direction
// holds the normal and the floor fit only has to find the distance.
//
// Thread-safety: pure.

#include <Eigen/Core>
#include <cstdint>
#include <opencv2/core.hpp>
#include <string>

namespace mm {

struct VerticalVanishingOptions {
  /// Largest angle between the found up direction and the expected one (degrees): the mount's
  /// pitch and the robot's sway are known to this much.
  double max_deviation_deg = 15.0;
  /// Segments shorter than this share of the image height do not vote (short ones fix no
  /// direction: a 1 px endpoint error turns a 20 px segment by 3 deg).
  double min_length_rel = 0.08;
  /// Endpoint error of a segment (pixels): a segment of length L is an inlier when its angle to
  /// the line towards the vanishing point is below 2 * sigma / L (both endpoints off by sigma).
  double endpoint_sigma_px = 1.0;
  /// The vanishing point needs this many inlier segments (and they must not all be one line).
  int min_inliers = 8;
  int iterations = 500;
  uint32_t seed = 1;
  [[nodiscard]] std::string Check() const;
};

struct VerticalVanishingPoint {
  bool found = false;
  std::string why_not;
  /// World up in the camera's frame (x right, y down, z forward), unit.
  Eigen::Vector3d up_in_cam = Eigen::Vector3d::Zero();
  int segments = 0;  ///< Candidate segments (long enough, near vertical).
  int inliers = 0;
  double inlier_length_px = 0.0;   ///< Sum of the inliers' lengths.
  double deviation_deg = 0.0;      ///< Between up_in_cam and the expected up.
  double rms_residual_deg = 0.0;   ///< Of the inliers' angles to the vanishing point's lines.
  /// The dominant horizontal direction ahead (within 60 deg of the optical axis) when its
  /// segments show one (else zero); up_in_cam is perpendicular to it.
  Eigen::Vector3d horizontal_in_cam = Eigen::Vector3d::Zero();
  int horizontal_inliers = 0;
};

/// `gray`: an undistorted 8-bit image seen through `K`; `expected_up_in_cam`: the mount's
/// nominal up (e.g. UpInCamera(pitch)).
VerticalVanishingPoint EstimateVerticalVanishingPoint(const cv::Mat& gray, const Eigen::Matrix3d& K,
                                                      const Eigen::Vector3d& expected_up_in_cam,
                                                      const VerticalVanishingOptions& options = {});

}  // namespace mm
