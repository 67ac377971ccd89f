#include "recon/two_view.h"

#include <Eigen/Geometry>
#include <Eigen/LU>
#include <Eigen/SVD>
#include <algorithm>
#include <cmath>
#include <numbers>
#include <opencv2/calib3d.hpp>
#include <opencv2/core/eigen.hpp>

namespace mm {
namespace {

double Median(std::vector<double> v) {
  if (v.empty()) return 0.0;
  const auto mid = v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2);
  std::nth_element(v.begin(), mid, v.end());
  return *mid;
}

Eigen::Matrix3d Skew(const Eigen::Vector3d& v) {
  Eigen::Matrix3d m;
  m << 0, -v.z(), v.y(), v.z(), 0, -v.x(), -v.y(), v.x(), 0;
  return m;
}

// Sampson distance of a correspondence to the epipolar constraint x_b^T E x_a = 0
// (Hartley & Zisserman, 2nd ed., eq. 11.9), in normalized coordinates.
double SampsonError(const Eigen::Matrix3d& e, const Eigen::Vector2d& x_a,
                    const Eigen::Vector2d& x_b) {
  const Eigen::Vector3d a = x_a.homogeneous();
  const Eigen::Vector3d b = x_b.homogeneous();
  const Eigen::Vector3d ea = e * a;
  const Eigen::Vector3d etb = e.transpose() * b;
  const double denom = ea.head<2>().squaredNorm() + etb.head<2>().squaredNorm();
  return denom > 0 ? b.dot(ea) / std::sqrt(denom) : 0.0;
}

// Levenberg-Marquardt on the Sampson errors of the inliers over the 5 degrees of freedom of
// (R, t): R <- exp([w]x) R, t <- normalize(t + B d) with B spanning the tangent plane of t.
void RefinePoseSampson(const std::vector<Eigen::Vector2d>& xa, const std::vector<Eigen::Vector2d>& xb,
                       const std::vector<int>& inliers, Eigen::Matrix3d* rotation,
                       Eigen::Vector3d* translation) {
  const int n = static_cast<int>(inliers.size());
  if (n < 8) return;
  auto residuals = [&](const Eigen::Matrix3d& r, const Eigen::Vector3d& t) {
    Eigen::VectorXd res(n);
    const Eigen::Matrix3d e = Skew(t) * r;
    for (int k = 0; k < n; ++k) {
      res[k] = SampsonError(e, xa[static_cast<size_t>(inliers[static_cast<size_t>(k)])],
                            xb[static_cast<size_t>(inliers[static_cast<size_t>(k)])]);
    }
    return res;
  };
  auto apply = [](const Eigen::Matrix3d& r, const Eigen::Vector3d& t,
                  const Eigen::Matrix<double, 5, 1>& d, Eigen::Matrix3d* r_out,
                  Eigen::Vector3d* t_out) {
    Eigen::Matrix<double, 3, 2> basis;
    const Eigen::Vector3d any = std::abs(t.x()) < 0.9 ? Eigen::Vector3d::UnitX()
                                                     : Eigen::Vector3d::UnitY();
    basis.col(0) = t.cross(any).normalized();
    basis.col(1) = t.cross(basis.col(0)).normalized();
    const Eigen::Vector3d w = d.head<3>();
    const double angle = w.norm();
    const Eigen::Matrix3d dr =
        angle > 0 ? Eigen::AngleAxisd(angle, w / angle).toRotationMatrix()
                  : Eigen::Matrix3d::Identity();
    *r_out = dr * r;
    *t_out = (t + basis * d.tail<2>()).normalized();
  };
  Eigen::Matrix3d r = *rotation;
  Eigen::Vector3d t = *translation;
  Eigen::VectorXd res = residuals(r, t);
  double cost = res.squaredNorm();
  double lambda = 1e-3;
  for (int iteration = 0; iteration < 30; ++iteration) {
    Eigen::MatrixXd jac(n, 5);
    const double h = 1e-7;
    for (int j = 0; j < 5; ++j) {
      Eigen::Matrix<double, 5, 1> d = Eigen::Matrix<double, 5, 1>::Zero();
      d[j] = h;
      Eigen::Matrix3d rp, rm;
      Eigen::Vector3d tp, tm;
      apply(r, t, d, &rp, &tp);
      apply(r, t, -d, &rm, &tm);
      jac.col(j) = (residuals(rp, tp) - residuals(rm, tm)) / (2 * h);
    }
    const Eigen::Matrix<double, 5, 5> jtj = jac.transpose() * jac;
    const Eigen::Matrix<double, 5, 1> jtr = jac.transpose() * res;
    bool improved = false;
    for (int tries = 0; tries < 10 && !improved; ++tries) {
      Eigen::Matrix<double, 5, 5> a = jtj;
      a.diagonal() *= 1.0 + lambda;
      const Eigen::Matrix<double, 5, 1> step = a.ldlt().solve(-jtr);
      Eigen::Matrix3d r_new;
      Eigen::Vector3d t_new;
      apply(r, t, step, &r_new, &t_new);
      const Eigen::VectorXd res_new = residuals(r_new, t_new);
      const double cost_new = res_new.squaredNorm();
      if (cost_new < cost) {
        improved = true;
        const bool converged = cost - cost_new < 1e-10 * cost;
        r = r_new;
        t = t_new;
        res = res_new;
        cost = cost_new;
        lambda = std::max(lambda * 0.1, 1e-9);
        if (converged) iteration = 1000;
      } else {
        lambda *= 10.0;
      }
    }
    if (!improved) break;
  }
  *rotation = r;
  *translation = t;
}

TwoViewResult Fail(TwoViewResult result, std::string reason) {
  result.success = false;
  result.failure_reason = std::move(reason);
  return result;
}

}  // namespace

std::string TwoViewOptions::Check() const {
  if (!(ransac_threshold_px > 0)) return "ransac_threshold_px: must be > 0";
  if (!(ransac_confidence > 0 && ransac_confidence < 1)) return "ransac_confidence: in (0, 1)";
  if (max_ransac_iterations < 1) return "max_ransac_iterations: must be >= 1";
  if (min_inliers < 5) return "min_inliers: must be >= 5";
  if (!(max_reprojection_error_px > 0)) return "max_reprojection_error_px: must be > 0";
  return {};
}

Eigen::Vector3d TriangulateDlt(const Eigen::Vector2d& x_a, const Eigen::Vector2d& x_b,
                               const Eigen::Matrix3d& rotation,
                               const Eigen::Vector3d& translation) {
  Eigen::Matrix<double, 3, 4> p_a = Eigen::Matrix<double, 3, 4>::Zero();
  p_a.leftCols<3>().setIdentity();
  Eigen::Matrix<double, 3, 4> p_b;
  p_b << rotation, translation;
  Eigen::Matrix4d a;
  a.row(0) = x_a.x() * p_a.row(2) - p_a.row(0);
  a.row(1) = x_a.y() * p_a.row(2) - p_a.row(1);
  a.row(2) = x_b.x() * p_b.row(2) - p_b.row(0);
  a.row(3) = x_b.y() * p_b.row(2) - p_b.row(1);
  const Eigen::JacobiSVD<Eigen::Matrix4d> svd(a, Eigen::ComputeFullV);
  const Eigen::Vector4d x = svd.matrixV().col(3);
  return x.head<3>() / x.w();
}

TwoViewResult EstimateTwoView(std::span<const Eigen::Vector2d> pixels_a,
                              std::span<const Eigen::Vector2d> pixels_b, const Eigen::Matrix3d& K,
                              const TwoViewOptions& options) {
  TwoViewResult result;
  result.num_correspondences = static_cast<int>(pixels_a.size());
  if (pixels_a.size() != pixels_b.size()) return Fail(result, "correspondence count mismatch");
  if (static_cast<int>(pixels_a.size()) < options.min_inliers) {
    return Fail(result, "too few matches (" + std::to_string(pixels_a.size()) + ")");
  }

  // Normalize with K^-1 (handles skew, which OpenCV's cameraMatrix path ignores).
  const Eigen::Matrix3d k_inv = K.inverse();
  std::vector<cv::Point2d> norm_a, norm_b;
  std::vector<Eigen::Vector2d> xa, xb;
  for (size_t i = 0; i < pixels_a.size(); ++i) {
    xa.push_back((k_inv * pixels_a[i].homogeneous()).hnormalized());
    xb.push_back((k_inv * pixels_b[i].homogeneous()).hnormalized());
    norm_a.emplace_back(xa.back().x(), xa.back().y());
    norm_b.emplace_back(xb.back().x(), xb.back().y());
  }
  const double focal = 0.5 * (K(0, 0) + K(1, 1));
  cv::theRNG().state = options.seed;
  cv::Mat inlier_mask;
  const cv::Mat essential = cv::findEssentialMat(
      norm_a, norm_b, cv::Mat::eye(3, 3, CV_64F), cv::RANSAC, options.ransac_confidence,
      options.ransac_threshold_px / focal, options.max_ransac_iterations, inlier_mask);
  if (essential.rows != 3 || essential.cols != 3) {
    return Fail(result, "no essential matrix found");
  }
  cv::Mat r_cv, t_cv;
  cv::Mat pose_mask = inlier_mask.clone();
  const int in_front = cv::recoverPose(essential, norm_a, norm_b, cv::Mat::eye(3, 3, CV_64F),
                                       r_cv, t_cv, pose_mask);
  cv::cv2eigen(r_cv, result.rotation);
  cv::cv2eigen(t_cv, result.translation);
  result.translation.normalize();
  result.num_inliers = in_front;
  if (in_front < options.min_inliers) {
    return Fail(result, "too few inliers in front of both cameras (" + std::to_string(in_front) +
                            ")");
  }
  // The RANSAC model comes from a minimal sample; refine it on all inliers, then take the
  // inlier set again under the refined model.
  std::vector<int> inliers;
  for (size_t i = 0; i < xa.size(); ++i) {
    if (pose_mask.at<uint8_t>(static_cast<int>(i)) != 0) inliers.push_back(static_cast<int>(i));
  }
  RefinePoseSampson(xa, xb, inliers, &result.rotation, &result.translation);
  const Eigen::Matrix3d refined_e = Skew(result.translation) * result.rotation;
  const double threshold = options.ransac_threshold_px / focal;
  for (size_t i = 0; i < xa.size(); ++i) {
    const bool inlier = std::abs(SampsonError(refined_e, xa[i], xb[i])) < threshold;
    pose_mask.at<uint8_t>(static_cast<int>(i)) = inlier ? 1 : 0;
  }

  // Triangulate each inlier; keep points in front of both cameras, with small reprojection
  // error and enough triangulation angle.
  const Eigen::Vector3d center_b = -result.rotation.transpose() * result.translation;
  std::vector<double> angles;
  double sq_error_sum = 0.0;
  for (size_t i = 0; i < xa.size(); ++i) {
    if (pose_mask.at<uint8_t>(static_cast<int>(i)) == 0) continue;
    const Eigen::Vector3d p = TriangulateDlt(xa[i], xb[i], result.rotation, result.translation);
    const Eigen::Vector3d p_b = result.rotation * p + result.translation;
    if (!(p.z() > 0) || !(p_b.z() > 0)) continue;
    const double err_a = ((K * p).hnormalized() - pixels_a[i]).norm();
    const double err_b = ((K * p_b).hnormalized() - pixels_b[i]).norm();
    const double err = std::max(err_a, err_b);
    if (err > options.max_reprojection_error_px) continue;
    const double cos_angle = p.normalized().dot((p - center_b).normalized());
    const double angle = std::acos(std::clamp(cos_angle, -1.0, 1.0)) * 180.0 / std::numbers::pi;
    angles.push_back(angle);
    if (angle < options.min_triangulation_angle_deg) continue;
    result.points_in_cam_a.push_back(p);
    result.point_correspondence.push_back(static_cast<int>(i));
    sq_error_sum += 0.5 * (err_a * err_a + err_b * err_b);
  }
  result.median_triangulation_angle_deg = Median(angles);
  if (!result.points_in_cam_a.empty()) {
    result.reprojection_rms_px =
        std::sqrt(sq_error_sum / static_cast<double>(result.points_in_cam_a.size()));
  }
  if (result.median_triangulation_angle_deg < options.min_median_triangulation_angle_deg) {
    return Fail(result, "too little parallax (median triangulation angle " +
                            std::to_string(result.median_triangulation_angle_deg) + " deg)");
  }
  if (static_cast<int>(result.points_in_cam_a.size()) < options.min_inliers) {
    return Fail(result, "too few triangulated points (" +
                            std::to_string(result.points_in_cam_a.size()) + ")");
  }
  result.success = true;
  return result;
}

}  // namespace mm
