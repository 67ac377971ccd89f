#include "recon/keyframe_gate.h"

#include <Eigen/Geometry>
#include <Eigen/LU>
#include <Eigen/SVD>
#include <algorithm>
#include <cmath>
#include <numbers>
#include <opencv2/calib3d.hpp>
#include <opencv2/core/eigen.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/video/tracking.hpp>

namespace mm {

namespace {

double Median(std::vector<double> v) {
  if (v.empty()) return 0.0;
  auto mid = v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2);
  std::nth_element(v.begin(), mid, v.end());
  return *mid;
}

}  // namespace

std::string KeyframeGateOptions::Check() const {
  if (!(parallax_deg > 0)) return "parallax_deg: must be > 0";
  if (max_corners < 8) return "max_corners: must be >= 8";
  if (min_tracks < 8) return "min_tracks: must be >= 8";
  if (min_inliers < 8) return "min_inliers: must be >= 8";
  if (!(max_homography_inlier_ratio > 0 && max_homography_inlier_ratio <= 1)) {
    return "max_homography_inlier_ratio: must be in (0, 1]";
  }
  if (!(ransac_threshold_px > 0)) return "ransac_threshold_px: must be > 0";
  if (ransac_iterations < 10) return "ransac_iterations: must be >= 10";
  return {};
}

KeyframeGate::KeyframeGate(const Eigen::Matrix3d& K, KeyframeGateOptions options)
    : K_(K), K_inv_(K.inverse()), options_(options) {}

int KeyframeGate::Start(const cv::Mat& gray_a) {
  CV_Assert(gray_a.type() == CV_8UC1);
  points_a_.clear();
  cv::goodFeaturesToTrack(gray_a, points_a_, options_.max_corners, options_.corner_quality,
                          options_.min_corner_distance_px);
  points_prev_ = points_a_;
  previous_ = gray_a.clone();
  return static_cast<int>(points_a_.size());
}

GateDecision KeyframeGate::Update(const cv::Mat& gray) {
  CV_Assert(gray.type() == CV_8UC1 && gray.size() == previous_.size());
  GateDecision d;
  if (points_prev_.size() >= 8) {
    // Track forward, then back: keep tracks that return to where they started (Kalal et al.,
    // forward-backward error, ICPR 2010).
    const cv::Size window(options_.klt_window_px, options_.klt_window_px);
    const cv::TermCriteria criteria(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, 20, 0.03);
    std::vector<cv::Point2f> next, back;
    std::vector<uchar> status, status_back;
    std::vector<float> error, error_back;
    cv::calcOpticalFlowPyrLK(previous_, gray, points_prev_, next, status, error, window,
                             options_.klt_levels, criteria);
    cv::calcOpticalFlowPyrLK(gray, previous_, next, back, status_back, error_back, window,
                             options_.klt_levels, criteria);
    std::vector<cv::Point2f> kept_a, kept_next;
    for (size_t i = 0; i < next.size(); ++i) {
      const bool inside = next[i].x >= 0 && next[i].y >= 0 && next[i].x < gray.cols - 1 &&
                          next[i].y < gray.rows - 1;
      const float fb = static_cast<float>(cv::norm(back[i] - points_prev_[i]));
      if (status[i] && status_back[i] && inside && error[i] < options_.max_klt_error &&
          fb < options_.max_forward_backward_px) {
        kept_a.push_back(points_a_[i]);
        kept_next.push_back(next[i]);
      }
    }
    points_a_ = std::move(kept_a);
    points_prev_ = std::move(kept_next);
  } else {
    points_a_.clear();
    points_prev_.clear();
  }
  previous_ = gray.clone();
  d.tracks = static_cast<int>(points_a_.size());
  if (d.tracks < options_.min_tracks) {
    d.verdict = GateDecision::Verdict::kLostTrack;
    d.reason = "lost track (" + std::to_string(d.tracks) + " tracks left, need " +
               std::to_string(options_.min_tracks) + ")";
    return d;
  }

  // Quick relative pose on normalized coordinates (K^-1 handles skew).
  std::vector<cv::Point2d> na, nb;
  std::vector<Eigen::Vector3d> rays_a, rays_b;
  for (size_t i = 0; i < points_a_.size(); ++i) {
    const Eigen::Vector3d a = K_inv_ * Eigen::Vector3d(points_a_[i].x, points_a_[i].y, 1.0);
    const Eigen::Vector3d b = K_inv_ * Eigen::Vector3d(points_prev_[i].x, points_prev_[i].y, 1.0);
    na.emplace_back(a.x() / a.z(), a.y() / a.z());
    nb.emplace_back(b.x() / b.z(), b.y() / b.z());
    rays_a.push_back(a.normalized());
    rays_b.push_back(b.normalized());
  }
  const double focal = 0.5 * (K_(0, 0) + K_(1, 1));
  const double threshold = options_.ransac_threshold_px / focal;
  cv::theRNG().state = 0;
  cv::Mat e_mask;
  const cv::Mat e = cv::findEssentialMat(na, nb, cv::Mat::eye(3, 3, CV_64F), cv::RANSAC, 0.99,
                                         threshold, options_.ransac_iterations, e_mask);
  cv::Mat h_mask;
  const cv::Mat h = cv::findHomography(na, nb, cv::RANSAC, threshold, h_mask,
                                       options_.ransac_iterations, 0.99);
  d.homography_inliers = h.empty() ? 0 : cv::countNonZero(h_mask);
  if (e.rows != 3 || e.cols != 3) {
    d.reason = "no essential fit";
    return d;
  }
  d.essential_inliers = cv::countNonZero(e_mask);

  // Rotation-compensated parallax. The best rotation-only explanation of the inlier tracks
  // (Wahba's problem, solved by SVD; Markley 1988) leaves the angle between each track's ray and
  // its ray from A rotated: what no camera rotation can produce. Pure rotation leaves ~0
  // (measured: <= 0.02 deg over 30 warped frames); translation leaves the part of the
  // triangulation angle a rotation cannot mimic (a lower bound on it: a rotation absorbs the
  // common component of lateral motion).
  std::vector<size_t> inliers;
  for (size_t i = 0; i < rays_a.size(); ++i) {
    if (e_mask.at<uint8_t>(static_cast<int>(i)) != 0) inliers.push_back(i);
  }
  Eigen::Matrix3d cross = Eigen::Matrix3d::Zero();
  for (size_t i : inliers) cross += rays_b[i] * rays_a[i].transpose();
  const Eigen::JacobiSVD<Eigen::Matrix3d> svd(cross, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d fix = Eigen::Matrix3d::Identity();
  fix(2, 2) = (svd.matrixU() * svd.matrixV().transpose()).determinant() < 0 ? -1.0 : 1.0;
  const Eigen::Matrix3d r_rot = svd.matrixU() * fix * svd.matrixV().transpose();
  std::vector<double> parallax;
  for (size_t i : inliers) {
    const double c = std::clamp((r_rot * rays_a[i]).dot(rays_b[i]), -1.0, 1.0);
    parallax.push_back(std::acos(c) * 180.0 / std::numbers::pi);
  }
  d.median_parallax_deg = Median(parallax);

  if (d.essential_inliers < options_.min_inliers) {
    d.reason = "too few inliers (" + std::to_string(d.essential_inliers) + ")";
  } else if (d.homography_inliers >=
             options_.max_homography_inlier_ratio * d.essential_inliers) {
    d.reason = "a homography explains the motion (rotation or plane)";
  } else if (d.median_parallax_deg < options_.parallax_deg) {
    d.reason = "not enough parallax yet";
  } else {
    d.verdict = GateDecision::Verdict::kTakeB;
    d.reason = "parallax reached";
  }
  return d;
}

}  // namespace mm
