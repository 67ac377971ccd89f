#include "recon/view_pose.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <opencv2/calib3d.hpp>
#include <opencv2/core/eigen.hpp>
#include <unordered_map>
#include <vector>

namespace mm {

std::string ViewPoseOptions::Check() const {
  if (!(threshold_px > 0)) return "view_pose.threshold_px must be > 0";
  if (min_inliers < 6) return "view_pose.min_inliers must be >= 6";
  if (!(min_inlier_share >= 0 && min_inlier_share <= 1)) {
    return "view_pose.min_inlier_share must be in [0, 1]";
  }
  if (!(max_pixel_a_offset_px >= 0 && max_pixel_a_offset_px < 1)) {
    return "view_pose.max_pixel_a_offset_px must be in [0, 1)";
  }
  if (ransac_iterations < 1) return "view_pose.ransac_iterations must be >= 1";
  return {};
}

PnpRansacPose SolvePnpRansacRefined(std::span<const Eigen::Vector3d> points,
                                    std::span<const Eigen::Vector2d> pixels,
                                    const Eigen::Matrix3d& K, const PnpRansacOptions& options) {
  PnpRansacPose out;
  if (points.size() != pixels.size() || points.size() < 4) return out;
  std::vector<cv::Point3d> object;
  std::vector<cv::Point2d> image;
  object.reserve(points.size());
  image.reserve(pixels.size());
  for (size_t i = 0; i < points.size(); ++i) {
    object.emplace_back(points[i].x(), points[i].y(), points[i].z());
    image.emplace_back(pixels[i].x(), pixels[i].y());
  }
  cv::Mat K_cv, rvec, tvec;
  cv::eigen2cv(K, K_cv);
  out.found =
      cv::solvePnPRansac(object, image, K_cv, cv::noArray(), rvec, tvec, false, options.iterations,
                         static_cast<float>(options.threshold_px), options.confidence, out.inliers,
                         options.sqpnp ? cv::SOLVEPNP_SQPNP : cv::SOLVEPNP_EPNP);
  if (!out.found || out.inliers.size() < 4) {
    out.found = false;
    return out;
  }
  std::vector<cv::Point3d> object_in;
  std::vector<cv::Point2d> image_in;
  for (int i : out.inliers) {
    object_in.push_back(object[static_cast<size_t>(i)]);
    image_in.push_back(image[static_cast<size_t>(i)]);
  }
  cv::solvePnPRefineLM(object_in, image_in, K_cv, cv::noArray(), rvec, tvec);
  cv::Mat R_cv;
  cv::Rodrigues(rvec, R_cv);
  cv::cv2eigen(R_cv, out.rotation);
  cv::cv2eigen(tvec, out.translation);
  return out;
}

ViewPose EstimateViewPose(std::span<const Eigen::Vector3d> points_in_a,
                          std::span<const Eigen::Vector2d> point_pixels_a,
                          std::span<const Eigen::Vector2d> pixels_a,
                          std::span<const Eigen::Vector2d> pixels_view, const Eigen::Matrix3d& K,
                          const ViewPoseOptions& options) {
  ViewPose out;
  if (std::string error = options.Check(); !error.empty()) {
    out.failure_reason = std::move(error);
    return out;
  }
  if (points_in_a.size() != point_pixels_a.size() || pixels_a.size() != pixels_view.size()) {
    out.failure_reason = "view pose: inputs of different lengths";
    return out;
  }
  // The points by the integer pixel of A they were seen at.
  auto key = [](const Eigen::Vector2d& p) {
    return (static_cast<int64_t>(std::lround(p.y())) << 32) ^
           static_cast<int64_t>(static_cast<uint32_t>(std::lround(p.x())));
  };
  std::unordered_multimap<int64_t, size_t> by_pixel;
  by_pixel.reserve(point_pixels_a.size());
  for (size_t i = 0; i < point_pixels_a.size(); ++i) by_pixel.emplace(key(point_pixels_a[i]), i);

  std::vector<Eigen::Vector3d> object;
  std::vector<Eigen::Vector2d> image;
  for (size_t j = 0; j < pixels_a.size(); ++j) {
    const auto [first, last] = by_pixel.equal_range(key(pixels_a[j]));
    for (auto it = first; it != last; ++it) {
      if ((point_pixels_a[it->second] - pixels_a[j]).norm() > options.max_pixel_a_offset_px) {
        continue;
      }
      object.push_back(points_in_a[it->second]);
      image.push_back(pixels_view[j]);
      break;
    }
  }
  out.correspondences_on_points = static_cast<int>(object.size());
  if (out.correspondences_on_points < options.min_inliers) {
    out.failure_reason = "view pose: " + std::to_string(object.size()) +
                         " correspondences on the pair's points (need " +
                         std::to_string(options.min_inliers) + ")";
    return out;
  }
  const PnpRansacPose pose = SolvePnpRansacRefined(
      object, image, K,
      {.threshold_px = options.threshold_px, .iterations = options.ransac_iterations});
  out.inliers = static_cast<int>(pose.inliers.size());
  const double share = static_cast<double>(out.inliers) / static_cast<double>(object.size());
  if (!pose.found || out.inliers < options.min_inliers || share < options.min_inlier_share) {
    out.failure_reason = "view pose: " + std::to_string(out.inliers) + " PnP inliers of " +
                         std::to_string(object.size());
    return out;
  }
  out.rotation_from_a = pose.rotation;
  out.translation_from_a = pose.translation;
  double sum_sq = 0;
  for (int i : pose.inliers) {
    const Eigen::Vector3d x =
        K * (pose.rotation * object[static_cast<size_t>(i)] + pose.translation);
    sum_sq += (x.hnormalized() - image[static_cast<size_t>(i)]).squaredNorm();
  }
  out.reprojection_rms_px = std::sqrt(sum_sq / static_cast<double>(out.inliers));
  out.success = true;
  return out;
}

}  // namespace mm
