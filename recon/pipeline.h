#pragma once
// Two keyframes -> relative pose, 3-D points and a textured mesh. The stages: SIFT on both
// (undistorted) keyframes, ratio-test matching, relative pose and triangulation (two_view.h),
// sub-pixel refinement of the points' observations in B (point_refinement.h), Delaunay mesh
// textured from keyframe A (mesh.h).
//
// Thread-safety: pure function; reentrant.

#include <array>
#include <opencv2/core.hpp>
#include <optional>
#include <span>
#include <string>
#include <string_view>

#include "calib/camera_model.h"
#include "recon/dense.h"
#include "recon/dense_mesh.h"
#include "recon/features.h"
#include "recon/mesh.h"
#include "recon/point_refinement.h"
#include "recon/two_view.h"
#include "recon/view_pose.h"

namespace mm {

/// One keyframe-gate track (KLT from A through every frame to B, forward-backward checked):
/// the same corner in A and in B, undistorted pixels.
struct TrackCorrespondence {
  Eigen::Vector2d pixel_a;
  Eigen::Vector2d pixel_b;
};

/// A source view of the dense stage beside B: a frame between A and B or shortly before A
/// (undistorted, A's size) with correspondences to A (the gate's tracks at that frame, tracks
/// back from A, or feature matches). Its pose comes from the pair's points
/// (recon/view_pose.h); which side of A it lies on follows from that pose.
struct SourceView {
  cv::Mat image;                                     ///< BGR8 or GRAY8.
  std::vector<TrackCorrespondence> correspondences;  ///< pixel_a in A, pixel_b in this view.
};

/// Which mesh a pair gets: the dense one (recon/dense_mesh.h, from the dense depth of A) or the
/// sparse one (recon/mesh.h, Delaunay of the triangulated points).
enum class MeshMode { kDense, kSparse };

/// "dense" / "sparse"; nullopt for another name.
std::optional<MeshMode> ParseMeshMode(std::string_view name);
const char* MeshModeName(MeshMode mode);

struct PairOptions {
  SiftOptions sift;
  MatchOptions match;
  TwoViewOptions two_view;
  PointRefinementOptions refinement;
  MeshMode mesh_mode = MeshMode::kDense;
  MeshOptions mesh;             ///< The sparse mesh (and the fallback of the dense one).
  DenseOptions dense;           ///< The dense depth (mesh_mode kDense).
  DenseMeshOptions dense_mesh;  ///< The dense mesh.
  /// Tracks join the SIFT matches as correspondences; a track whose A pixel lies within this
  /// of a matched SIFT keypoint in A is the same point twice and is left out.
  double track_duplicate_px = 2.0;
  ViewPoseOptions view_pose;  ///< Source views' poses.
  /// Of the source views between A and B (centre on B's side of A) whose pose was found, the
  /// dense sweep takes this many: those whose distance from A is nearest half of B's (each
  /// view's sweep costs about as much as B's; halfway, the view sees much of what B's
  /// occludes, and with a different baseline).
  int max_intermediate_views = 1;
  /// Of the source views before A (centre on the side of A away from B), the same: a view
  /// behind A sees the part of A's image that B's motion moves out of view (A's border when
  /// moving forward, the trailing side when moving sideways) and the other side of A's
  /// occlusions.
  int max_views_before_a = 1;
  /// A source view is used only when its distance from A is within this share of B's.
  std::array<double, 2> intermediate_baseline_share = {0.2, 0.8};
  /// Free the calling thread's SIFT pyramid (kept between calls, about 100 MB at 640x480)
  /// once B's features are out, before matching, the dense stage and the mesh: the
  /// appliance's peak memory falls by that much, and the next keyframe A's SIFT (computed
  /// while the gate waits for B) allocates it again.
  bool release_sift_workspace_after_b = false;
  [[nodiscard]] std::string Check() const;
};

struct StageTimes {
  double features_a_s = 0;
  double features_b_s = 0;
  double matching_s = 0;
  double geometry_s = 0;  ///< Two-view geometry and the point refinement.
  double dense_s = 0;     ///< The dense depth (mesh_mode kDense).
  double meshing_s = 0;
  [[nodiscard]] double total_s() const {
    return features_a_s + features_b_s + matching_s + geometry_s + dense_s + meshing_s;
  }
};

struct PairReconstruction {
  bool success = false;
  std::string failure_reason;
  int features_a = 0;
  int features_b = 0;
  int matches = 0;        ///< SIFT matches.
  int tracks = 0;         ///< Gate tracks given.
  int tracks_used = 0;    ///< Of those, not duplicates of a SIFT match (appended after them).
  int track_inliers = 0;  ///< Epipolar inliers among the tracks used.
  TwoViewResult geometry;
  std::vector<Eigen::Vector2d> point_pixels_a;  ///< Where each 3-D point was observed in A.
  std::vector<Eigen::Vector2d> point_pixels_b;  ///< Where each 3-D point was observed in B.
  PointRefinementSummary refinement;
  /// The mesh the pair got: kDense only when the dense mesh has triangles, else the sparse one
  /// (with the dense stage's failure in dense_failure_reason).
  MeshMode mesh_mode = MeshMode::kSparse;
  Mesh mesh;
  MeshSummary mesh_summary;             ///< The sparse mesh's (when it was built).
  DenseMeshSummary dense_mesh_summary;  ///< The dense mesh's.
  double dense_valid_fraction = 0;      ///< Share of A (shrunk) with a dense depth.
  /// The dense depth as points in A's frame, every 4th pixel of the shrunk map each way.
  std::vector<Eigen::Vector3d> dense_points_in_a;
  int dense_planes = 0;
  std::string dense_failure_reason;
  /// Source views given, and those whose pose was found and joined the dense sweep (the
  /// others' reasons in intermediate_failures), of which views_before_a_used lie before A.
  int intermediate_views = 0;
  int intermediate_views_used = 0;
  int views_before_a_used = 0;
  std::vector<std::string> intermediate_failures;
  StageTimes times;

  /// The scene's surfaces as points in A's frame: the dense depth's when there is one (the
  /// floor fit of scale/ gets thousands of floor points, not tens), else the sparse points.
  [[nodiscard]] std::span<const Eigen::Vector3d> SurfacePointsInA() const {
    return dense_points_in_a.empty() ? std::span<const Eigen::Vector3d>(geometry.points_in_cam_a)
                                     : std::span<const Eigen::Vector3d>(dense_points_in_a);
  }
};

/// Reconstructs a pair of undistorted frames (BGR8 or GRAY8) seen through `camera` (no
/// distortion expected). Data failures are reported in the result, never thrown.
PairReconstruction ReconstructPair(const cv::Mat& image_a, const cv::Mat& image_b,
                                   const BouguetCamera& camera, const PairOptions& options,
                                   std::span<const SourceView> between = {});

/// 8-bit gray of a BGR8 or GRAY8 image (a GRAY8 image is returned as it is, not copied).
cv::Mat ToGray(const cv::Mat& image);

/// Expresses the pair in other units: the translation, the points, the mesh vertices and the
/// voxel size times `metres_per_unit` (e.g. metres from scale/metric_scale.h; rotations,
/// pixels and angles keep). After it, |translation| is the baseline in the new units.
void ScalePairReconstruction(double metres_per_unit, PairReconstruction* pair);

/// SIFT of one keyframe (BGR8 or GRAY8) with `options.sift`: computed for keyframe A once,
/// while the appliance waits for B.
Features ExtractKeyframeFeatures(const cv::Mat& image, const PairOptions& options);

/// A source view from a frame (BGR8 or GRAY8, A's size) whose correspondences with A
/// come from SIFT matching against A's features (where no gate tracked the frame, e.g. a
/// keyframe list in `monomesh eval`).
SourceView MatchSourceView(const Features& features_a, const cv::Mat& image,
                           const PairOptions& options);
/// As above, with the frame's features already extracted (ExtractKeyframeFeatures).
SourceView MatchSourceView(const Features& features_a, const cv::Mat& image,
                           const Features& features, const PairOptions& options);

/// The source views the dense stage sweeps beside B.
struct ChosenSourceViews {
  std::vector<DenseView> views;       ///< Grey images with their poses from A.
  int before_a = 0;                   ///< Of them, those before A.
  std::vector<std::string> left_out;  ///< Why each of the others was not taken.
};

/// Poses each source view from the pair's points (`geometry`'s points, seen in A at
/// `point_pixels_a`) by its correspondences with A (recon/view_pose.h), keeps those at
/// `options.intermediate_baseline_share` of B's distance from A, and takes, on each side of A
/// (between A and B: the centre on B's side of the plane through A normal to the baseline;
/// before A: on the other), the `options.max_intermediate_views` and
/// `options.max_views_before_a` nearest halfway.
ChosenSourceViews ChooseSourceViews(std::span<const SourceView> between,
                                    const TwoViewResult& geometry,
                                    std::span<const Eigen::Vector2d> point_pixels_a,
                                    const Eigen::Matrix3d& K, cv::Size image_size,
                                    const PairOptions& options);

/// As above, with keyframe A's features precomputed by ExtractKeyframeFeatures (the time
/// after B arrives; `times.features_a_s` stays 0), and the keyframe gate's tracks from A to B
/// as further correspondences (a pair with weak SIFT matching across the baseline still has
/// enough inliers). `between`: frames between A and B for the dense stage (mesh_mode kDense).
PairReconstruction ReconstructPair(const Features& features_a, const cv::Mat& image_a,
                                   const cv::Mat& image_b, const BouguetCamera& camera,
                                   const PairOptions& options,
                                   std::span<const TrackCorrespondence> tracks = {},
                                   std::span<const SourceView> between = {});

}  // namespace mm
