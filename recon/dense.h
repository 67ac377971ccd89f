#pragma once
// Dense inverse depth of keyframe A from the pair, after the pose: a plane sweep (Collins 1996;
// Gallup et al., CVPR 2007) over fronto-parallel planes of A, uniform in inverse depth, with a
// zero-mean normalized cross-correlation cost, aggregated by semi-global matching along eight
// image paths (Hirschmueller, PAMI 2008), winner-take-all with a parabola for the sub-plane
// position. The sweep warps B into A by the plane's homography H = K (R + t rho e3^T) K^-1, so
// it needs no rectification and works for sideways and forward motion alike (the epipole may
// lie inside the image). Further views (frames between A and B, posed by recon/view_pose.h)
// are swept the same way and their costs combined with B's per pixel and plane: where the views
// agree they average, where one does not see the point (occluded in it) the better one counts.
// A pixel keeps its depth when the aggregated cost has a clear minimum,
// its window is textured and matches B at that depth, or it is textureless and its depth came
// from textured neighbours; small isolated regions are removed (speckle filter), depth edges
// are cut back to A's grey-level outlines where the window carried the foreground's depth past
// them, holes whose border lies on one plane are filled with it, and the band next to a depth
// edge where B sees the foreground instead of A's background (foreground fattening) is
// dropped.
// The method and its measured alternatives: docs/recon_tuning.md.
//
// Thread-safety: pure functions; reentrant (scratch volumes are kept per thread).

#include <Eigen/Core>
#include <opencv2/core.hpp>
#include <span>
#include <string>

namespace mm {

struct DenseOptions {
  /// The sweep runs on A and B shrunk by this integer factor (1 = full resolution).
  int downscale = 2;
  /// ZNCC window radius in pixels of the shrunk images (window = 2 r + 1).
  int window_radius = 3;
  /// Plane spacing: neighbouring planes move a pixel of A by about this many pixels in B (in
  /// the shrunk images), so that the parabola is not locked to the planes on short baselines
  /// (docs/recon_tuning.md). Longer baselines reach `max_planes` first and are spaced wider.
  double plane_step_px = 0.35;
  int min_planes = 16;
  int max_planes = 64;  ///< Beyond it the planes are spaced wider (sub-plane parabola).
  /// The sweep's inverse-depth range: the sparse points' 2nd and 98th percentiles of inverse
  /// depth, widened by these factors (near: times, far: divided by).
  double near_margin = 1.5;
  double far_margin = 2.0;
  /// Semi-global matching penalties for a one-plane and a larger jump between neighbours, in
  /// units of (1 - ZNCC) (cost range 0..2).
  double penalty_small = 0.08;
  double penalty_large = 0.6;
  /// The large penalty shrinks where A's grey level steps by more than this between
  /// neighbours on a path (P2 * tau / step): depth edges follow image edges. 0 = constant.
  int edge_tau = 8;
  /// A window whose grey-level standard deviation is below this carries no cost of its own.
  double min_texture_std = 1.0;
  /// A textured pixel keeps its depth only when its own window matches B there this well.
  double min_zncc = 0.5;
  /// Confidence = 1 - best / second-best aggregated cost (second outside best +- 1 plane).
  double min_confidence = 0.02;
  /// Connected regions of similar depth (within `speckle_planes` planes) smaller than this
  /// share of the shrunk image are removed.
  double max_speckle_fraction = 0.005;
  int speckle_planes = 2;
  /// Holes (connected pixels without depth) up to this share of the shrunk image that are
  /// surrounded by depth on one plane (the border's inverse depth affine in the pixel within
  /// the depth-edge tolerance) are filled with that plane: rejects inside a wall, the floor or
  /// a desk. Holes between surfaces and larger ones stay holes.
  double max_hole_fraction = 0.005;
  /// Depth edges snap to A's outlines: a near pixel up to the window radius from a farther
  /// surface is dropped when the largest grey-level step on the line from that surface into
  /// the near one lies behind it (the window carried the foreground's depth past the
  /// object's outline), if that step is at least this many grey levels. 0 = off.
  int edge_snap_min_step = 8;
  /// With further views (frames between A and B) a pixel's cost at a plane is the better
  /// view's plus half the difference up to this cap (1 - ZNCC units): views that agree are
  /// averaged (less noise), and a view that does not see the point (occluded in it, or A's
  /// window straddles an edge there) costs at most cap / 2 (Kang, Szeliski & Chai, CVPR 2001,
  /// take the better views for the same reason).
  double max_view_disagreement = 0.125;
  /// Foreground fattening: a pixel whose depth is nearer than a pixel's at most this many
  /// pixels (shrunk image) away along its epipolar direction (away from the epipole, where B
  /// hides A's background behind the foreground) is dropped. 0 = off.
  int occlusion_band_px = 5;
  [[nodiscard]] std::string Check() const;
};

struct DenseDepth {
  bool success = false;
  std::string failure_reason;
  /// Inverse depth of A's pixels in the shrunk image (CV_32FC1, 1/scene units); 0 = none.
  cv::Mat inverse_depth;
  /// Confidence in [0, 1] (CV_32FC1, same size); 0 where inverse_depth is 0.
  cv::Mat confidence;
  /// Camera matrix of the shrunk image.
  Eigen::Matrix3d K = Eigen::Matrix3d::Identity();
  int downscale = 1;
  double inverse_depth_min = 0;  ///< The sweep's range.
  double inverse_depth_max = 0;
  int planes = 0;
  double inverse_depth_step = 0;  ///< Between neighbouring planes: the depth's resolution.
  double valid_fraction = 0;      ///< Share of the shrunk image with a depth.
  /// The clean-up's work, in pixels of the shrunk image (recon/depth_filters.h).
  int cut_to_outlines = 0;
  int filled_in_holes = 0;
  int dropped_in_occlusion_bands = 0;
};

/// A further view of A's scene (a frame between A and B): its grey image (size of A's) and
/// pose, x_view = R x_a + t in the units of B's translation.
struct DenseView {
  cv::Mat gray;
  Eigen::Matrix3d rotation_from_a = Eigen::Matrix3d::Identity();
  Eigen::Vector3d translation_from_a = Eigen::Vector3d::Zero();
};

/// Inverse depth of keyframe A. `gray_a`, `gray_b`: undistorted 8-bit grey images of one size
/// seen through K; `rotation_b_from_a`, `translation_b_from_a`: x_b = R x_a + t;
/// `sparse_points_in_cam_a`: the triangulated points (for the depth range; >= 10 in front);
/// `extra_views`: further views of the scene in the same units (B sets the planes).
DenseDepth ComputeDenseDepth(const cv::Mat& gray_a, const cv::Mat& gray_b, const Eigen::Matrix3d& K,
                             const Eigen::Matrix3d& rotation_b_from_a,
                             const Eigen::Vector3d& translation_b_from_a,
                             std::span<const Eigen::Vector3d> sparse_points_in_cam_a,
                             const DenseOptions& options,
                             std::span<const DenseView> extra_views = {});

/// Inverse depth at a full-resolution pixel of A (bilinear in the shrunk map over the valid
/// neighbours, the nearest one across a depth edge); 0 when the nearest has no depth.
double InverseDepthAt(const DenseDepth& depth, double u, double v);

}  // namespace mm
