#include "recon/two_view.h"

#include <Eigen/Geometry>
#include <Eigen/LU>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <opencv2/calib3d.hpp>
#include <opencv2/core/eigen.hpp>
#include <utility>

#include "base/clock.h"

namespace mm {
namespace {

using Clock = std::chrono::steady_clock;

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

TwoViewResult Fail(TwoViewResult result, TwoViewFailure failure, std::string reason) {
  result.success = false;
  result.failure = failure;
  result.failure_reason = std::move(reason);
  return result;
}

TwoViewFailure FailureOf(PairKind kind) {
  switch (kind) {
    case PairKind::kGeneral:
      return TwoViewFailure::kNone;
    case PairKind::kPlanar:
      return TwoViewFailure::kPlanar;
    case PairKind::kRotation:
      return TwoViewFailure::kRotation;
    case PairKind::kNoParallax:
      return TwoViewFailure::kNoParallax;
  }
  return TwoViewFailure::kNone;
}

std::string TooLittleParallax(double median_deg) {
  return "too little parallax (median triangulation angle " + std::to_string(median_deg) + " deg)";
}

// Planar scene with translation: the pose from H (Faugeras & Lustman 1988 decomposition as in
// Malis & Vargas 2007, cv::decomposeHomographyMat), as ORB-SLAM initialises from H when H
// explains the pair. A candidate scores the correspondences it explains: Sampson error under
// E = [t]x R below the threshold and the point in front of both cameras; the points off the
// plane break the twofold ambiguity of the decomposition. The winner must be clear.
CheiralityResult PoseFromHomography(const Eigen::Matrix3d& h, const Eigen::Matrix3d& k,
                                    const std::vector<Eigen::Vector2d>& xa,
                                    const std::vector<Eigen::Vector2d>& xb, double threshold,
                                    const CheiralityOptions& options) {
  CheiralityResult out;
  cv::Mat h_cv, k_cv;
  cv::eigen2cv(h, h_cv);
  cv::eigen2cv(k, k_cv);
  std::vector<cv::Mat> rotations, translations, normals;
  const int n = cv::decomposeHomographyMat(h_cv, k_cv, rotations, translations, normals);
  std::vector<std::pair<int, RelativePose>> scored;
  for (int c = 0; c < n; ++c) {
    RelativePose pose;
    Eigen::Vector3d t;
    cv::cv2eigen(rotations[static_cast<size_t>(c)], pose.rotation);
    cv::cv2eigen(translations[static_cast<size_t>(c)], t);
    if (!(t.norm() > 1e-9)) continue;  // No translation: nothing to triangulate.
    pose.translation = t.normalized();
    const Eigen::Matrix3d e = Skew(pose.translation) * pose.rotation;
    int explained = 0;
    for (size_t i = 0; i < xa.size(); ++i) {
      if (!(std::abs(SampsonError(e, xa[i], xb[i])) < threshold)) continue;
      const Eigen::Vector3d p = TriangulateLinear(xa[i], xb[i], pose);
      const Eigen::Vector3d p_b = pose.rotation * p + pose.translation;
      explained += p.z() > 0 && p_b.z() > 0 ? 1 : 0;
    }
    scored.emplace_back(explained, pose);
  }
  std::sort(scored.begin(), scored.end(),
            [](const auto& x, const auto& y) { return x.first > y.first; });
  if (scored.empty() || scored.front().first == 0) {
    out.failure_reason = "planar scene: no pose from the homography explains the points";
    return out;
  }
  if (scored.size() > 1 && scored[1].first > options.max_runner_up_ratio * scored.front().first) {
    out.failure_reason = "planar scene: the homography's poses are ambiguous (" +
                         std::to_string(scored.front().first) + " vs " +
                         std::to_string(scored[1].first) + " points)";
    return out;
  }
  out.success = true;
  out.pose = scored.front().second;
  out.in_front[0] = scored.front().first;
  return out;
}

}  // namespace

const char* TwoViewFailureName(TwoViewFailure failure) {
  switch (failure) {
    case TwoViewFailure::kNone:
      return "none";
    case TwoViewFailure::kInput:
      return "input";
    case TwoViewFailure::kTooFewMatches:
      return "too_few_matches";
    case TwoViewFailure::kNoModel:
      return "no_model";
    case TwoViewFailure::kNoParallax:
      return "no_parallax";
    case TwoViewFailure::kRotation:
      return "rotation";
    case TwoViewFailure::kPlanar:
      return "planar";
    case TwoViewFailure::kTooFewInliers:
      return "too_few_inliers";
    case TwoViewFailure::kCheirality:
      return "cheirality";
    case TwoViewFailure::kTooFewPoints:
      return "too_few_points";
  }
  return "?";
}

bool MoreMotionMayCure(TwoViewFailure failure) {
  return failure == TwoViewFailure::kNoParallax || failure == TwoViewFailure::kRotation ||
         failure == TwoViewFailure::kPlanar || failure == TwoViewFailure::kCheirality;
}

TwoViewProbe ProbeTwoView(std::span<const Eigen::Vector2d> pixels_a,
                          std::span<const Eigen::Vector2d> pixels_b, const Eigen::Matrix3d& K,
                          const TwoViewOptions& options) {
  TwoViewProbe probe;
  auto fail = [&probe](TwoViewFailure failure, std::string reason) {
    probe.failure = failure;
    probe.failure_reason = std::move(reason);
    return probe;
  };
  if (pixels_a.size() != pixels_b.size()) {
    return fail(TwoViewFailure::kInput, "correspondence count mismatch");
  }
  if (static_cast<int>(pixels_a.size()) < options.min_inliers) {
    return fail(TwoViewFailure::kTooFewMatches,
                "too few matches (" + std::to_string(pixels_a.size()) + ")");
  }

  // 1. F and H by RANSAC in pixels; classify the pair.
  RansacOptions ransac;
  ransac.threshold_px = options.ransac_threshold_px;
  ransac.confidence = options.ransac_confidence;
  ransac.max_iterations = options.max_ransac_iterations;
  ransac.seed = options.seed;
  ransac.local_optimization = options.lo_ransac;
  ransac.refine_iterations = options.f_refine_iterations;
  auto start = Clock::now();
  probe.ransac_f = RansacFundamental(pixels_a, pixels_b, ransac);
  probe.ransac_f_s = SecondsSince(start);
  if (!probe.ransac_f.success) {
    return fail(TwoViewFailure::kNoModel, "F: " + probe.ransac_f.failure_reason);
  }
  start = Clock::now();
  ransac.seed = options.seed + 1;
  ransac.refine_iterations = 0;
  ransac.local_optimization = false;
  ransac.threshold_px = options.classify.homography_threshold_px;
  // H only serves the classification, which needs H to explain > 85 % of the points: such an
  // H is found in ~15 samples (H&Z alg. 4.5), so 200 suffice.
  ransac.max_iterations = std::min(ransac.max_iterations, 200);
  probe.ransac_h = RansacHomography(pixels_a, pixels_b, ransac);
  probe.ransac_h_s = SecondsSince(start);
  probe.classification =
      ClassifyPair(pixels_a, pixels_b, probe.ransac_f, probe.ransac_h, K, options.classify);
  const bool planar = probe.classification.kind == PairKind::kPlanar && options.planar_from_h;
  if (probe.classification.kind != PairKind::kGeneral && !planar) {
    return fail(FailureOf(probe.classification.kind), probe.classification.explanation);
  }
  if (static_cast<int>(probe.ransac_f.inliers.size()) < options.min_inliers) {
    return fail(TwoViewFailure::kTooFewInliers,
                "too few F inliers (" + std::to_string(probe.ransac_f.inliers.size()) + ")");
  }

  // 2. E on the manifold, the four poses, cheirality over all inliers; for a planar scene
  // (F ill-conditioned) the pose from H instead.
  start = Clock::now();
  const Eigen::Matrix3d k_inv = K.inverse();
  std::vector<Eigen::Vector2d>& xa = probe.norm_a;
  std::vector<Eigen::Vector2d>& xb = probe.norm_b;
  xa.reserve(pixels_a.size());
  xb.reserve(pixels_a.size());
  for (size_t i = 0; i < pixels_a.size(); ++i) {
    xa.push_back((k_inv * pixels_a[i].homogeneous()).hnormalized());
    xb.push_back((k_inv * pixels_b[i].homogeneous()).hnormalized());
  }
  if (planar) {
    const double focal = 0.5 * (K(0, 0) + K(1, 1));
    probe.cheirality = PoseFromHomography(probe.ransac_h.model, K, xa, xb,
                                          options.ransac_threshold_px / focal, options.cheirality);
  }
  if (!planar || !probe.cheirality.success) {
    // A planar pair whose H poses stay ambiguous (nearly every point on the plane) still has
    // F's points off the plane: F's pose is taken when its cheirality winner is clear.
    const Eigen::Matrix3d essential = EssentialFromFundamental(probe.ransac_f.model, K);
    CheiralityResult from_f =
        SelectPoseByCheirality(essential, xa, xb, probe.ransac_f.inliers, options.cheirality);
    if (!planar || from_f.success) probe.cheirality = std::move(from_f);
  }
  probe.pose_s = SecondsSince(start);
  if (!probe.cheirality.success) {
    return fail(TwoViewFailure::kCheirality, probe.cheirality.failure_reason);
  }

  // 3. The parallax test on the linear triangulation of the inliers in front.
  std::vector<double> angles;
  angles.reserve(probe.ransac_f.inliers.size());
  for (int i : probe.ransac_f.inliers) {
    const auto u = static_cast<size_t>(i);
    const Eigen::Vector3d p = TriangulateLinear(xa[u], xb[u], probe.cheirality.pose);
    const Eigen::Vector3d p_b =
        probe.cheirality.pose.rotation * p + probe.cheirality.pose.translation;
    if (!(p.z() > 0) || !(p_b.z() > 0) || !p.allFinite()) continue;
    angles.push_back(TriangulationAngleDeg(p, probe.cheirality.pose));
  }
  probe.median_triangulation_angle_deg = MedianOf(angles);
  if (probe.median_triangulation_angle_deg < options.min_median_triangulation_angle_deg) {
    return fail(TwoViewFailure::kNoParallax,
                TooLittleParallax(probe.median_triangulation_angle_deg));
  }
  probe.accepted = true;
  return probe;
}

std::string TwoViewOptions::Check() const {
  if (!(ransac_threshold_px > 0)) return "ransac_threshold_px: must be > 0";
  if (!(ransac_confidence > 0 && ransac_confidence < 1)) return "ransac_confidence: in (0, 1)";
  if (max_ransac_iterations < 1) return "max_ransac_iterations: must be >= 1";
  if (f_refine_iterations < 0) return "f_refine_iterations: must be >= 0";
  if (min_inliers < 8) return "min_inliers: must be >= 8";
  if (!(max_reprojection_error_px > 0)) return "max_reprojection_error_px: must be > 0";
  if (!(max_reprojection_error_after_ba_px > 0)) {
    return "max_reprojection_error_after_ba_px: must be > 0";
  }
  if (!(min_triangulation_angle_deg >= 0)) return "min_triangulation_angle_deg: must be >= 0";
  if (!(min_median_triangulation_angle_deg >= 0)) {
    return "min_median_triangulation_angle_deg: must be >= 0";
  }
  for (const std::string& p : {bundle.Check(), cheirality.Check(), classify.Check()}) {
    if (!p.empty()) return p;
  }
  return {};
}

TwoViewResult EstimateTwoView(std::span<const Eigen::Vector2d> pixels_a,
                              std::span<const Eigen::Vector2d> pixels_b, const Eigen::Matrix3d& K,
                              const TwoViewOptions& options) {
  TwoViewResult result;
  result.num_correspondences = static_cast<int>(pixels_a.size());

  // 1-2. F and H by RANSAC, the classification, E and the pose by cheirality (the probe the
  // keyframe gate applies too). Its parallax test on the linear triangulation is not applied
  // here: the test below, after the refinement, decides.
  TwoViewProbe probe = ProbeTwoView(pixels_a, pixels_b, K, options);
  result.ransac_f = probe.ransac_f;
  result.ransac_h = probe.ransac_h;
  result.classification = probe.classification;
  result.cheirality = probe.cheirality;
  result.times.ransac_f_s = probe.ransac_f_s;
  result.times.ransac_h_s = probe.ransac_h_s;
  // Only the probe's own parallax test (after the pose) is left to the test below.
  if (!probe.accepted &&
      !(probe.failure == TwoViewFailure::kNoParallax && probe.cheirality.success)) {
    return Fail(result, probe.failure, probe.failure_reason);
  }
  auto start = Clock::now();
  const std::vector<Eigen::Vector2d> xa = std::move(probe.norm_a);
  const std::vector<Eigen::Vector2d> xb = std::move(probe.norm_b);
  result.rotation = result.cheirality.pose.rotation;
  result.translation = result.cheirality.pose.translation;

  // 3. LM on the Sampson error over the 5 dof of (R, t), then the inliers again, until the
  // inlier set is stable (H&Z algorithm 11.4 step (v): iterate until the number of
  // correspondences is stable). Measured on the TUM pairs against two fixed rounds: depth
  // (0, 3) 1.23 -> 1.10 %, step-2/3 p90 tails lower, step-1 medians within seed noise.
  const double focal = 0.5 * (K(0, 0) + K(1, 1));
  const double threshold = options.ransac_threshold_px / focal;
  std::vector<int> inliers = result.ransac_f.inliers;
  for (int round = 0; round < 10; ++round) {
    RefinePoseSampson(xa, xb, inliers, &result.rotation, &result.translation);
    const Eigen::Matrix3d e = Skew(result.translation) * result.rotation;
    std::vector<int> next;
    for (size_t i = 0; i < xa.size(); ++i) {
      if (std::abs(SampsonError(e, xa[i], xb[i])) < threshold) {
        next.push_back(static_cast<int>(i));
      }
    }
    const bool same = next == inliers;
    inliers = std::move(next);
    if (same) break;
  }
  result.inliers = inliers;
  result.num_inliers = static_cast<int>(inliers.size());
  result.times.pose_s = probe.pose_s + SecondsSince(start);  // E and cheirality, then LM.
  if (result.num_inliers < options.min_inliers) {
    return Fail(result, TwoViewFailure::kTooFewInliers,
                "too few inliers after refinement (" + std::to_string(result.num_inliers) + ")");
  }

  // 4. Triangulation: linear, then Gauss-Newton; cheirality, reprojection and angle checks.
  start = Clock::now();
  RelativePose pose{result.rotation, result.translation};
  TwoViewBundleProblem problem;
  problem.k = K;
  std::vector<int> kept;
  std::vector<double> angles;
  for (int i : inliers) {
    const auto u = static_cast<size_t>(i);
    Eigen::Vector3d p = TriangulateLinear(xa[u], xb[u], pose);
    p = RefineTriangulation(p, xa[u], xb[u], pose);
    const Eigen::Vector3d p_b = pose.rotation * p + pose.translation;
    if (!(p.z() > 0) || !(p_b.z() > 0) || !p.allFinite()) continue;
    const Eigen::Vector2d err = ReprojectionErrorsPx(K, p, p_b, pixels_a[u], pixels_b[u]);
    if (std::max(err.x(), err.y()) > options.max_reprojection_error_px) continue;
    // Low-angle points stay in the BA (they pin down the rotation); they are dropped from
    // the output after it.
    angles.push_back(TriangulationAngleDeg(p, pose));
    problem.points.push_back(p);
    problem.observations_a.push_back(pixels_a[u]);
    problem.observations_b.push_back(pixels_b[u]);
    kept.push_back(i);
  }
  result.times.triangulation_s = SecondsSince(start);
  // Parallax gate on all triangulated inliers, before any are dropped for their angle.
  result.median_triangulation_angle_deg = MedianOf(angles);
  if (result.median_triangulation_angle_deg < options.min_median_triangulation_angle_deg) {
    result.classification.kind = PairKind::kNoParallax;
    result.classification.explanation = TooLittleParallax(result.median_triangulation_angle_deg);
    return Fail(result, TwoViewFailure::kNoParallax, result.classification.explanation);
  }
  if (static_cast<int>(kept.size()) < options.min_inliers) {
    return Fail(result, TwoViewFailure::kTooFewPoints,
                "too few triangulated points (" + std::to_string(kept.size()) + ")");
  }

  // 5. Two-view BA; points above the reprojection limit after it are removed and BA runs
  // again on the rest (once).
  start = Clock::now();
  if (options.bundle_adjustment) {
    for (int round = 0; round < 2; ++round) {
      problem.rotation = result.rotation;
      problem.translation = result.translation;
      result.bundle = AdjustTwoViewBundle(options.bundle, &problem);
      result.rotation = problem.rotation;
      result.translation = problem.translation;
      if (round == 1) break;
      TwoViewBundleProblem clean;
      clean.k = K;
      std::vector<int> clean_kept;
      for (size_t j = 0; j < kept.size(); ++j) {
        const Eigen::Vector3d& p = problem.points[j];
        const Eigen::Vector3d p_b = result.rotation * p + result.translation;
        if (!(p.z() > 0) || !(p_b.z() > 0)) continue;
        const Eigen::Vector2d err = ReprojectionErrorsPx(K, p, p_b, problem.observations_a[j],
                                                         problem.observations_b[j]);
        if (std::max(err.x(), err.y()) > options.max_reprojection_error_after_ba_px) continue;
        clean.points.push_back(p);
        clean.observations_a.push_back(problem.observations_a[j]);
        clean.observations_b.push_back(problem.observations_b[j]);
        clean_kept.push_back(kept[j]);
      }
      if (clean_kept.size() == kept.size()) break;
      problem = std::move(clean);
      kept = std::move(clean_kept);
    }
  }
  pose = RelativePose{result.rotation, result.translation};
  double sq_sum = 0;
  angles.clear();
  const double max_err = options.bundle_adjustment ? options.max_reprojection_error_after_ba_px
                                                   : options.max_reprojection_error_px;
  for (size_t j = 0; j < kept.size(); ++j) {
    const Eigen::Vector3d& p = problem.points[j];
    const Eigen::Vector3d p_b = pose.rotation * p + pose.translation;
    if (!(p.z() > 0) || !(p_b.z() > 0)) continue;
    const Eigen::Vector2d err =
        ReprojectionErrorsPx(K, p, p_b, problem.observations_a[j], problem.observations_b[j]);
    if (std::max(err.x(), err.y()) > max_err) continue;
    const double angle = TriangulationAngleDeg(p, pose);
    if (angle < options.min_triangulation_angle_deg) continue;
    angles.push_back(angle);
    result.points_in_cam_a.push_back(p);
    result.point_correspondence.push_back(kept[j]);
    sq_sum += 0.5 * (err.x() * err.x() + err.y() * err.y());
  }
  result.times.bundle_s = SecondsSince(start);
  if (!angles.empty()) result.median_triangulation_angle_deg = MedianOf(angles);
  if (!result.points_in_cam_a.empty()) {
    result.reprojection_rms_px =
        std::sqrt(sq_sum / static_cast<double>(result.points_in_cam_a.size()));
  }
  if (static_cast<int>(result.points_in_cam_a.size()) < options.min_inliers) {
    return Fail(result, TwoViewFailure::kTooFewPoints,
                "too few points after bundle adjustment (" +
                    std::to_string(result.points_in_cam_a.size()) + ")");
  }
  result.success = true;
  return result;
}

}  // namespace mm
