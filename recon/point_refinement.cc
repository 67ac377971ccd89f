#include "recon/point_refinement.h"

#include <Eigen/Geometry>
#include <cmath>
#include <opencv2/video/tracking.hpp>

#include "recon/epipolar.h"

namespace mm {

std::string PointRefinementOptions::Check() const {
  if (window_px < 5 || window_px % 2 == 0) return "window_px: must be odd and >= 5";
  if (pyramid_levels < 0 || pyramid_levels > 4) return "pyramid_levels: must be in [0, 4]";
  if (!(max_shift_px > 0)) return "max_shift_px: must be > 0";
  if (!(max_forward_backward_px > 0)) return "max_forward_backward_px: must be > 0";
  if (max_iterations < 1) return "max_iterations: must be >= 1";
  return {};
}

std::vector<Eigen::Vector2d> RefineObservationsLk(const cv::Mat& gray_a, const cv::Mat& gray_b,
                                                  std::span<const Eigen::Vector2d> pixels_a,
                                                  std::span<const Eigen::Vector2d> pixels_b,
                                                  const PointRefinementOptions& options,
                                                  std::vector<bool>* accepted) {
  CV_Assert(gray_a.type() == CV_8UC1 && gray_b.type() == CV_8UC1);
  CV_Assert(pixels_a.size() == pixels_b.size());
  std::vector<Eigen::Vector2d> out(pixels_b.begin(), pixels_b.end());
  if (accepted != nullptr) accepted->assign(out.size(), false);
  if (out.empty()) return out;
  std::vector<cv::Point2f> a, b, back;
  for (size_t i = 0; i < out.size(); ++i) {
    a.emplace_back(static_cast<float>(pixels_a[i].x()), static_cast<float>(pixels_a[i].y()));
    b.emplace_back(static_cast<float>(pixels_b[i].x()), static_cast<float>(pixels_b[i].y()));
  }
  back = a;
  const cv::Size window(options.window_px, options.window_px);
  const cv::TermCriteria stop(cv::TermCriteria::COUNT | cv::TermCriteria::EPS,
                              options.max_iterations, 0.01);
  std::vector<uchar> forward_ok, backward_ok;
  std::vector<float> residual;
  cv::calcOpticalFlowPyrLK(gray_a, gray_b, a, b, forward_ok, residual, window,
                           options.pyramid_levels, stop, cv::OPTFLOW_USE_INITIAL_FLOW);
  cv::calcOpticalFlowPyrLK(gray_b, gray_a, b, back, backward_ok, residual, window,
                           options.pyramid_levels, stop, cv::OPTFLOW_USE_INITIAL_FLOW);
  for (size_t i = 0; i < out.size(); ++i) {
    if (forward_ok[i] == 0 || backward_ok[i] == 0) continue;
    const Eigen::Vector2d refined(b[i].x, b[i].y);
    const Eigen::Vector2d returned(back[i].x, back[i].y);
    if (!refined.allFinite() || (refined - pixels_b[i]).norm() > options.max_shift_px) continue;
    if ((returned - pixels_a[i]).norm() > options.max_forward_backward_px) continue;
    out[i] = refined;
    if (accepted != nullptr) (*accepted)[i] = true;
  }
  return out;
}

PointRefinementSummary RefinePoints(const cv::Mat& gray_a, const cv::Mat& gray_b,
                                    const Eigen::Matrix3d& K, const TwoViewOptions& two_view,
                                    const PointRefinementOptions& options,
                                    std::span<const Eigen::Vector2d> point_pixels_a,
                                    std::vector<Eigen::Vector2d>* point_pixels_b,
                                    TwoViewResult* result) {
  PointRefinementSummary summary;
  if (!options.enabled || !result->success) return summary;
  const size_t n = result->points_in_cam_a.size();
  CV_Assert(point_pixels_a.size() == n && point_pixels_b->size() == n);
  summary.points = static_cast<int>(n);
  std::vector<bool> accepted;
  const std::vector<Eigen::Vector2d> refined =
      RefineObservationsLk(gray_a, gray_b, point_pixels_a, *point_pixels_b, options, &accepted);

  const RelativePose pose{result->rotation, result->translation};
  const Eigen::Matrix3d k_inv = K.inverse();
  std::vector<double> shifts, angles;
  double sq_sum = 0;
  for (size_t j = 0; j < n; ++j) {
    Eigen::Vector3d& p = result->points_in_cam_a[j];
    Eigen::Vector2d& observed_b = (*point_pixels_b)[j];
    if (accepted[j]) {
      const Eigen::Vector2d xa = (k_inv * point_pixels_a[j].homogeneous()).hnormalized();
      const Eigen::Vector2d xb = (k_inv * refined[j].homogeneous()).hnormalized();
      const Eigen::Vector3d q = RefineTriangulation(p, xa, xb, pose);
      const Eigen::Vector3d q_b = pose.rotation * q + pose.translation;
      const Eigen::Vector2d err = ReprojectionErrorsPx(K, q, q_b, point_pixels_a[j], refined[j]);
      if (q.allFinite() && q.z() > 0 && q_b.z() > 0 &&
          std::max(err.x(), err.y()) <= two_view.max_reprojection_error_after_ba_px &&
          TriangulationAngleDeg(q, pose) >= two_view.min_triangulation_angle_deg) {
        shifts.push_back((refined[j] - observed_b).norm());
        p = q;
        observed_b = refined[j];
      }
    }
    const Eigen::Vector3d p_b = pose.rotation * p + pose.translation;
    const Eigen::Vector2d err = ReprojectionErrorsPx(K, p, p_b, point_pixels_a[j], observed_b);
    sq_sum += 0.5 * (err.x() * err.x() + err.y() * err.y());
    angles.push_back(TriangulationAngleDeg(p, pose));
  }
  summary.refined = static_cast<int>(shifts.size());
  if (!shifts.empty()) summary.median_shift_px = MedianOf(shifts);
  if (n > 0) {
    result->reprojection_rms_px = std::sqrt(sq_sum / static_cast<double>(n));
    result->median_triangulation_angle_deg = MedianOf(angles);
  }
  return summary;
}

}  // namespace mm
