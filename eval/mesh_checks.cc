#include "eval/mesh_checks.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <opencv2/imgproc.hpp>
#include <vector>

#include "base/stats.h"

namespace mm {

double ScaleFromPoints(std::span<const Eigen::Vector3d> points_in_cam,
                       std::span<const Eigen::Vector2d> pixels, const cv::Mat& gt_depth_m) {
  CV_Assert(gt_depth_m.type() == CV_32FC1);
  std::vector<double> ratios;
  for (size_t i = 0; i < points_in_cam.size() && i < pixels.size(); ++i) {
    const int u = static_cast<int>(std::lround(pixels[i].x()));
    const int v = static_cast<int>(std::lround(pixels[i].y()));
    if (u < 0 || v < 0 || u >= gt_depth_m.cols || v >= gt_depth_m.rows) continue;
    const float gt = gt_depth_m.at<float>(v, u);
    if (gt > 0 && points_in_cam[i].z() > 0) ratios.push_back(gt / points_in_cam[i].z());
  }
  if (ratios.empty()) return 0.0;
  return QuantileOf(std::move(ratios), 0.5);
}

MeshDepthEval EvaluateMeshDepth(Renderer& renderer, const Mesh& mesh, const RenderCamera& camera,
                                const cv::Mat& gt_depth_m, double scale) {
  MeshDepthEval out;
  if (gt_depth_m.type() != CV_32FC1 || gt_depth_m.cols != camera.width ||
      gt_depth_m.rows != camera.height) {
    out.failure_reason = "ground truth must be CV_32FC1 of the camera's image size";
    return out;
  }
  if (!(scale > 0)) {
    out.failure_reason = "scale must be > 0";
    return out;
  }
  RenderCamera cam = camera;
  cam.far_plane = FarPlaneFor(mesh, camera.cam_from_world);
  cam.near_plane = cam.far_plane * 1e-4;
  const RenderResult r = renderer.Render(mesh, cv::Mat(), cam);
  if (!r.success) {
    out.failure_reason = r.failure_reason;
    return out;
  }
  std::vector<double> errors, ratios;
  for (int y = 0; y < gt_depth_m.rows; ++y) {
    for (int x = 0; x < gt_depth_m.cols; ++x) {
      const float gt = gt_depth_m.at<float>(y, x);
      if (!(gt > 0)) continue;
      ++out.gt_pixels;
      const float d = r.depth.at<float>(y, x);
      if (!(d > 0)) continue;
      ++out.covered_pixels;
      errors.push_back(std::abs(scale * d - gt) / gt);
      ratios.push_back(scale * d / gt);
    }
  }
  if (out.gt_pixels == 0) {
    out.failure_reason = "no ground-truth pixels";
    return out;
  }
  out.coverage = static_cast<double>(out.covered_pixels) / out.gt_pixels;
  if (!errors.empty()) {
    const auto off = std::count_if(errors.begin(), errors.end(), [](double e) { return e > 0.10; });
    out.flying = static_cast<double>(off) / static_cast<double>(errors.size());
    out.median_rel_err = QuantileOf(errors, 0.5);
    out.median_ratio = QuantileOf(std::move(ratios), 0.5);
    out.p90_rel_err = QuantileOf(std::move(errors), 0.9);
  }
  out.success = true;
  return out;
}

MeshDepthEval EvaluateMeshDepth(const Mesh& mesh, const RenderCamera& camera,
                                const cv::Mat& gt_depth_m, double scale) {
  Renderer renderer;
  return EvaluateMeshDepth(renderer, mesh, camera, gt_depth_m, scale);
}

MeshDepthEval EvaluatePairMesh(const PairReconstruction& pair, const Eigen::Matrix3d& K,
                               const cv::Mat& gt_depth_m) {
  MeshDepthEval out;
  if (!pair.success) {
    out.failure_reason = "the pair failed: " + pair.failure_reason;
    return out;
  }
  if (gt_depth_m.type() != CV_32FC1) {
    out.failure_reason = "ground truth must be CV_32FC1 (metres)";
    return out;
  }
  const double scale =
      ScaleFromPoints(pair.geometry.points_in_cam_a, pair.point_pixels_a, gt_depth_m);
  if (!(scale > 0)) {
    out.failure_reason = "no triangulated point has ground-truth depth";
    return out;
  }
  RenderCamera camera;
  camera.K = K;
  camera.width = gt_depth_m.cols;
  camera.height = gt_depth_m.rows;
  return EvaluateMeshDepth(pair.mesh, camera, gt_depth_m, scale);
}

double MaskedNcc(const cv::Mat& a, const cv::Mat& b, const cv::Mat& mask) {
  CV_Assert(a.size() == b.size() && a.size() == mask.size() && mask.type() == CV_8UC1);
  cv::Mat ga = a, gb = b;
  if (a.channels() == 3) cv::cvtColor(a, ga, cv::COLOR_BGR2GRAY);
  if (b.channels() == 3) cv::cvtColor(b, gb, cv::COLOR_BGR2GRAY);
  double sa = 0, sb = 0, saa = 0, sbb = 0, sab = 0;
  long n = 0;
  for (int y = 0; y < a.rows; ++y) {
    for (int x = 0; x < a.cols; ++x) {
      if (mask.at<uint8_t>(y, x) == 0) continue;
      const double va = ga.at<uint8_t>(y, x), vb = gb.at<uint8_t>(y, x);
      sa += va;
      sb += vb;
      saa += va * va;
      sbb += vb * vb;
      sab += va * vb;
      ++n;
    }
  }
  if (n < 2) return 0.0;
  const double cov = sab - sa * sb / static_cast<double>(n);
  const double var_a = saa - sa * sa / static_cast<double>(n);
  const double var_b = sbb - sb * sb / static_cast<double>(n);
  if (!(var_a > 0 && var_b > 0)) return 0.0;
  return cov / std::sqrt(var_a * var_b);
}

}  // namespace mm
