#pragma once
// Two-view estimators (Hartley & Zisserman, Multiple View Geometry, 2nd ed.; "H&Z" below):
// normalized 8-point fundamental matrix (alg. 11.1), RANSAC for F with Sampson distance and an
// adaptive number of samples (alg. 11.4 / 4.5), Levenberg-Marquardt refinement of F on the
// Sampson error of the inliers (sec. 11.4.3), normalized DLT homography (alg. 4.2) and its
// RANSAC, E = K^T F K projected to the essential manifold (sec. 9.6), the four (R, t) of an
// essential matrix (result 9.19) with cheirality over all inliers, linear triangulation
// (sec. 12.2) refined by Gauss-Newton on the reprojection error, and the pair classification
// (general / planar / pure rotation / too little parallax).
//
// Conventions: pixels_a[i] <-> pixels_b[i]; F satisfies x_b^T F x_a = 0; H maps a to b;
// poses are cam_b_from_cam_a (X_b = R X_a + t).
// Thread-safety: pure functions; reentrant. Same input and seed, same output.

#include <Eigen/Core>
#include <array>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "base/stats.h"

namespace mm {

using Points2 = std::span<const Eigen::Vector2d>;

/// Normalized 8-point algorithm (H&Z alg. 11.1) on >= 8 correspondences: Hartley
/// normalization, least-squares null vector, rank 2 by SVD. Unit Frobenius norm. nullopt when
/// the points are degenerate (fewer than 8, or coincident).
std::optional<Eigen::Matrix3d> EightPointFundamental(Points2 a, Points2 b);

/// Squared Sampson distance of (a, b) to x_b^T F x_a = 0 (H&Z eq. 11.9), in pixels^2.
double SampsonDistanceSq(const Eigen::Matrix3d& f, const Eigen::Vector2d& a,
                         const Eigen::Vector2d& b);

/// Normalized DLT homography (H&Z alg. 4.2), x_b ~ H x_a, on >= 4 correspondences.
std::optional<Eigen::Matrix3d> DltHomography(Points2 a, Points2 b);

/// Symmetric transfer error |H a - b|^2 + |H^-1 b - a|^2 (H&Z eq. 4.7), pixels^2.
double SymmetricTransferErrorSq(const Eigen::Matrix3d& h, const Eigen::Matrix3d& h_inv,
                                const Eigen::Vector2d& a, const Eigen::Vector2d& b);

struct RansacOptions {
  double threshold_px = 1.0;      ///< Inlier if the (Sampson / transfer) distance is below.
  double confidence = 0.9999;     ///< Adaptive stop: P(an all-inlier sample was drawn).
  int max_iterations = 10000;     ///< Hard cap on samples.
  int min_iterations = 50;        ///< Never fewer samples (guards a lucky early sample).
  unsigned seed = 0;              ///< std::mt19937 seed: runs are deterministic.
  int refine_iterations = 20;     ///< LM iterations of the refinement on the inliers (0: none).
  /// LO-RANSAC (Chum, Matas & Kittler, DAGM 2003; the "LO+" variant of Lebeda et al. 2012):
  /// every time a sample gives a new best model, its inliers are refitted by least squares
  /// (the 8-point / DLT fit on all of them and on `lo_inner_samples` random subsets of them),
  /// each fit refined by `lo_steps` rounds of least squares on its inliers with the threshold
  /// shrinking from lo_threshold_multiplier * t to t; the best MSAC score wins. The adaptive
  /// stop then uses the optimized model's inlier count.
  bool local_optimization = false;
  int lo_inner_samples = 4;       ///< Random non-minimal subsets of the inliers per run.
  int lo_steps = 4;               ///< Iterated least-squares rounds per fit.
  double lo_threshold_multiplier = 3.0;
  [[nodiscard]] std::string Check() const;
};

struct RansacResult {
  bool success = false;
  std::string failure_reason;
  Eigen::Matrix3d model = Eigen::Matrix3d::Identity();  ///< F or H, unit Frobenius norm.
  std::vector<int> inliers;       ///< Indices under the final (refined) model.
  int iterations = 0;             ///< Samples drawn.
  int required_iterations = 0;    ///< Adaptive N at the end (H&Z alg. 4.5).
  int num_inliers_minimal = 0;    ///< Inliers of the best sample's model (after LO if on).
  int local_optimizations = 0;    ///< LO runs (new best samples) and those that improved it.
  int local_improvements = 0;
  double inlier_rms_px = 0.0;     ///< RMS distance of the inliers under the final model.
};

/// RANSAC for F (H&Z alg. 11.4 with 8-point samples): MSAC score on the Sampson distance,
/// adaptive N, then LM refinement on the inliers and the inlier set taken again.
RansacResult RansacFundamental(Points2 a, Points2 b, const RansacOptions& options);

/// Levenberg-Marquardt on the Sampson distances of the given correspondences over the 9
/// entries of F (renormalized and projected to rank 2 after every step; H&Z sec. 11.4.3).
Eigen::Matrix3d RefineFundamentalSampson(const Eigen::Matrix3d& f, Points2 a, Points2 b,
                                         std::span<const int> inliers, int max_iterations);

/// RANSAC for H (4-point DLT samples, symmetric transfer error < 2 threshold^2, MSAC score),
/// refit on the inliers.
RansacResult RansacHomography(Points2 a, Points2 b, const RansacOptions& options);

/// E = K^T F K projected to the essential manifold: singular values (s, s, 0) with
/// s = (s1 + s2) / 2 (H&Z sec. 9.6.1), unit Frobenius norm.
Eigen::Matrix3d EssentialFromFundamental(const Eigen::Matrix3d& f, const Eigen::Matrix3d& k);

struct RelativePose {
  Eigen::Matrix3d rotation = Eigen::Matrix3d::Identity();  ///< cam_b_from_cam_a.
  Eigen::Vector3d translation = Eigen::Vector3d::Zero();   ///< Unit norm.
};

/// The four (R, t) of E = [t]x R (H&Z result 9.19): (UWV^T, +u3), (UWV^T, -u3), (UW^TV^T, +u3),
/// (UW^TV^T, -u3), with det R = +1.
std::array<RelativePose, 4> DecomposeEssential(const Eigen::Matrix3d& e);

/// Linear (DLT) triangulation in normalized coordinates, A = [I|0], B = [R|t]; point in A.
Eigen::Vector3d TriangulateLinear(const Eigen::Vector2d& x_a, const Eigen::Vector2d& x_b,
                                  const RelativePose& pose);

/// Gauss-Newton on the sum of squared reprojection errors in both views (normalized
/// coordinates) from `initial`; returns the refined point.
Eigen::Vector3d RefineTriangulation(const Eigen::Vector3d& initial, const Eigen::Vector2d& x_a,
                                    const Eigen::Vector2d& x_b, const RelativePose& pose,
                                    int iterations = 5);

/// Reprojection errors (pixels) of one point in both views of a camera with intrinsics `k`:
/// (|proj(k p_a) - pixel_a|, |proj(k p_b) - pixel_b|), with p_a and p_b the point in camera A
/// and in camera B.
Eigen::Vector2d ReprojectionErrorsPx(const Eigen::Matrix3d& k, const Eigen::Vector3d& p_a,
                                     const Eigen::Vector3d& p_b, const Eigen::Vector2d& pixel_a,
                                     const Eigen::Vector2d& pixel_b);

/// Angle (degrees) between the rays from the two camera centres to point `p_a` (in camera A).
double TriangulationAngleDeg(const Eigen::Vector3d& p_a, const RelativePose& pose);

struct CheiralityOptions {
  double max_runner_up_ratio = 0.7;  ///< Reject when 2nd-best has > this share of best's count.
  [[nodiscard]] std::string Check() const;
};

struct CheiralityResult {
  bool success = false;
  std::string failure_reason;
  RelativePose pose;
  int winner = -1;                   ///< Index into DecomposeEssential's four.
  std::array<int, 4> in_front{};     ///< Points in front of both cameras, per candidate.
};

/// Cheirality over all given correspondences (normalized coordinates): each of the four poses
/// triangulates every inlier and counts points in front of both cameras; the winner must be
/// clear (runner-up <= max_runner_up_ratio of the winner's count).
CheiralityResult SelectPoseByCheirality(const Eigen::Matrix3d& e, Points2 norm_a, Points2 norm_b,
                                        std::span<const int> inliers,
                                        const CheiralityOptions& options);

enum class PairKind { kGeneral, kPlanar, kRotation, kNoParallax };
const char* PairKindName(PairKind kind);

struct ClassifyOptions {
  double min_median_flow_px = 1.5;   ///< Median |b - a| below: no parallax (same image).
  double homography_share = 0.85;    ///< H inliers / F inliers above: H explains the pair.
  /// H's inlier threshold (per direction). H's residual is 2-D and sees the noise of both
  /// points where Sampson's is 1-D, so it is looser than F's 1 px: at sigma = 0.5 px both then
  /// keep ~85-90 % of true inliers (measured on the synthetic scenes).
  double homography_threshold_px = 2.0;
  double max_rotation_deviation = 0.03;  ///< K^-1 H K is a rotation if its singular values
                                         ///< are within this relative spread.
  [[nodiscard]] std::string Check() const;
};

struct PairClassification {
  PairKind kind = PairKind::kGeneral;
  double median_flow_px = 0.0;
  int f_inliers = 0;
  int h_inliers = 0;
  double h_share = 0.0;               ///< h_inliers / f_inliers.
  double rotation_deviation = 0.0;    ///< 1 - s3/s1 of K^-1 H K.
  std::string explanation;
};

/// Classifies a pair from its correspondences and the RANSAC results of F and H (Torr's
/// model-selection idea, simplified to inlier shares): no parallax when the image barely
/// moves; pure rotation when H explains the pair and K^-1 H K is a rotation; planar when H
/// explains it otherwise; general else. The parallax gate after triangulation can still
/// downgrade a general pair to no parallax.
PairClassification ClassifyPair(Points2 a, Points2 b, const RansacResult& f,
                                const RansacResult& h, const Eigen::Matrix3d& k,
                                const ClassifyOptions& options);

// MedianOf (the upper median of a copy; 0 for an empty vector) is base/stats.h's.

}  // namespace mm
