#pragma once
// Checks a mesh against images and ground-truth depth by rendering it (render/renderer.h).
//
// Thread-safety: functions taking a Renderer use it from the calling thread (see Renderer).

#include <Eigen/Core>
#include <opencv2/core.hpp>
#include <span>
#include <string>

#include "recon/mesh.h"
#include "recon/pipeline.h"
#include "render/renderer.h"

namespace mm {

struct MeshDepthEval {
  bool success = false;
  std::string failure_reason;
  int gt_pixels = 0;            ///< Pixels with ground-truth depth (> 0).
  int covered_pixels = 0;       ///< Of those, pixels the mesh covers.
  double coverage = 0.0;        ///< covered_pixels / gt_pixels.
  double median_rel_err = 0.0;  ///< |scale * d_mesh - d_gt| / d_gt over covered pixels.
  double p90_rel_err = 0.0;
  /// Median of scale * d_mesh / d_gt: a bias (a scale or pose off) moves it from 1, noise
  /// does not.
  double median_ratio = 0.0;
  /// Share of the covered pixels off by more than 10 % ("flying": surfaces where there are
  /// none, usually bridges over depth discontinuities).
  double flying = 0.0;
};

/// The metric scale of an up-to-scale reconstruction from its triangulated points, not the
/// mesh: the median of gt_depth(pixel) / z over the points whose pixel has ground truth
/// (nearest pixel). `gt_depth_m` is CV_32FC1 in metres, 0 = missing. Returns 0 when no point
/// has ground truth.
double ScaleFromPoints(std::span<const Eigen::Vector3d> points_in_cam,
                       std::span<const Eigen::Vector2d> pixels, const cv::Mat& gt_depth_m);

/// Renders the mesh's depth from `camera` (gt's image size) and compares scale * depth with
/// `gt_depth_m` (CV_32FC1, metres, 0 = missing) over the pixels that have both.
MeshDepthEval EvaluateMeshDepth(Renderer& renderer, const Mesh& mesh, const RenderCamera& camera,
                                const cv::Mat& gt_depth_m, double scale);

/// Same, with a renderer of its own (EGL set-up costs ~40 ms).
MeshDepthEval EvaluateMeshDepth(const Mesh& mesh, const RenderCamera& camera,
                                const cv::Mat& gt_depth_m, double scale);

/// For `monomesh eval`: the pair's mesh against keyframe A's ground-truth depth (CV_32FC1,
/// metres, 0 = missing, A's image size), the scale from the pair's triangulated points
/// (ScaleFromPoints). JSON: "mesh": {"coverage", "depth_rel_err": {"median", "p90"}}.
MeshDepthEval EvaluatePairMesh(const PairReconstruction& pair, const Eigen::Matrix3d& K,
                               const cv::Mat& gt_depth_m);

/// Normalized cross-correlation of the grey levels of two BGR8 (or GRAY8) images over the
/// pixels where `mask` is non-zero; 0 when fewer than 2 pixels or no variance.
double MaskedNcc(const cv::Mat& a, const cv::Mat& b, const cv::Mat& mask);

}  // namespace mm
