#include "recon/epipolar.h"

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>
#include <Eigen/LU>
#include <Eigen/SVD>
#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <numbers>
#include <random>

namespace mm {
namespace {

// Hartley normalization (H&Z sec. 4.4.4): centroid to the origin, mean distance sqrt(2).
Eigen::Matrix3d NormalizingTransform(Points2 p, std::span<const int> subset) {
  Eigen::Vector2d mean = Eigen::Vector2d::Zero();
  const auto n = static_cast<double>(subset.size());
  for (int i : subset) mean += p[static_cast<size_t>(i)];
  mean /= n;
  double dist = 0;
  for (int i : subset) dist += (p[static_cast<size_t>(i)] - mean).norm();
  dist /= n;
  const double s = dist > 1e-12 ? std::sqrt(2.0) / dist : 1.0;
  Eigen::Matrix3d t;
  t << s, 0, -s * mean.x(), 0, s, -s * mean.y(), 0, 0, 1;
  return t;
}

std::vector<int> AllIndices(size_t n) {
  std::vector<int> v(n);
  for (size_t i = 0; i < n; ++i) v[i] = static_cast<int>(i);
  return v;
}

Eigen::Matrix3d EnforceRank2(const Eigen::Matrix3d& f) {
  Eigen::JacobiSVD<Eigen::Matrix3d> svd(f, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Vector3d s = svd.singularValues();
  s[2] = 0;
  const Eigen::Matrix3d out = svd.matrixU() * s.asDiagonal() * svd.matrixV().transpose();
  return out / out.norm();
}

std::optional<Eigen::Matrix3d> EightPointOnSubset(Points2 a, Points2 b, std::span<const int> s) {
  if (s.size() < 8) return std::nullopt;
  const Eigen::Matrix3d ta = NormalizingTransform(a, s);
  const Eigen::Matrix3d tb = NormalizingTransform(b, s);
  Eigen::Matrix<double, 9, 9> ata = Eigen::Matrix<double, 9, 9>::Zero();
  for (int i : s) {
    const Eigen::Vector3d xa = ta * a[static_cast<size_t>(i)].homogeneous();
    const Eigen::Vector3d xb = tb * b[static_cast<size_t>(i)].homogeneous();
    Eigen::Matrix<double, 9, 1> row;
    row << xb.x() * xa.x(), xb.x() * xa.y(), xb.x(), xb.y() * xa.x(), xb.y() * xa.y(), xb.y(),
        xa.x(), xa.y(), 1.0;
    ata.noalias() += row * row.transpose();
  }
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix<double, 9, 9>> eig(ata);
  if (eig.info() != Eigen::Success) return std::nullopt;
  const Eigen::Matrix<double, 9, 1> v = eig.eigenvectors().col(0);
  Eigen::Matrix3d fn;
  fn << v[0], v[1], v[2], v[3], v[4], v[5], v[6], v[7], v[8];
  const Eigen::Matrix3d f = tb.transpose() * EnforceRank2(fn) * ta;
  if (!f.allFinite() || f.norm() < 1e-300) return std::nullopt;
  return f / f.norm();
}

std::optional<Eigen::Matrix3d> DltOnSubset(Points2 a, Points2 b, std::span<const int> s) {
  if (s.size() < 4) return std::nullopt;
  const Eigen::Matrix3d ta = NormalizingTransform(a, s);
  const Eigen::Matrix3d tb = NormalizingTransform(b, s);
  Eigen::Matrix<double, 9, 9> ata = Eigen::Matrix<double, 9, 9>::Zero();
  for (int i : s) {
    const Eigen::Vector3d xa = ta * a[static_cast<size_t>(i)].homogeneous();
    const Eigen::Vector3d xb = tb * b[static_cast<size_t>(i)].homogeneous();
    Eigen::Matrix<double, 9, 1> r1, r2;
    r1 << 0, 0, 0, -xa.x(), -xa.y(), -1, xb.y() * xa.x(), xb.y() * xa.y(), xb.y();
    r2 << xa.x(), xa.y(), 1, 0, 0, 0, -xb.x() * xa.x(), -xb.x() * xa.y(), -xb.x();
    ata.noalias() += r1 * r1.transpose() + r2 * r2.transpose();
  }
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix<double, 9, 9>> eig(ata);
  if (eig.info() != Eigen::Success) return std::nullopt;
  const Eigen::Matrix<double, 9, 1> v = eig.eigenvectors().col(0);
  Eigen::Matrix3d hn;
  hn << v[0], v[1], v[2], v[3], v[4], v[5], v[6], v[7], v[8];
  const Eigen::Matrix3d h = tb.inverse() * hn * ta;
  if (!h.allFinite() || std::abs(h.determinant()) < 1e-300) return std::nullopt;
  return h / h.norm();
}

double Sampson(const Eigen::Matrix3d& f, const Eigen::Vector2d& a, const Eigen::Vector2d& b) {
  const Eigen::Vector3d ah = a.homogeneous();
  const Eigen::Vector3d bh = b.homogeneous();
  const Eigen::Vector3d fa = f * ah;
  const Eigen::Vector3d ftb = f.transpose() * bh;
  const double den = fa.head<2>().squaredNorm() + ftb.head<2>().squaredNorm();
  return den > 0 ? bh.dot(fa) / std::sqrt(den) : 0.0;
}

// H&Z alg. 4.5: samples needed to draw one all-inlier sample with probability `confidence`.
int RequiredIterations(double inlier_share, int sample_size, double confidence, int cap) {
  const double w = std::pow(inlier_share, sample_size);
  if (w >= 1.0) return 1;
  if (w <= 0.0) return cap;
  const double n = std::log(1.0 - confidence) / std::log(1.0 - w);
  return static_cast<int>(std::min<double>(cap, std::ceil(n)));
}

using FitFn = std::function<std::optional<Eigen::Matrix3d>(std::span<const int>)>;
using ErrorFn = std::function<void(const Eigen::Matrix3d&, std::vector<double>*)>;

// MSAC score (Torr & Zisserman 2000): sum of min(e, t^2); `count` receives the inliers.
double MsacScore(const std::vector<double>& err, double threshold_sq, int* count) {
  double score = 0;
  int c = 0;
  for (double e : err) {
    if (e < threshold_sq) {
      score += e;
      ++c;
    } else {
      score += threshold_sq;
    }
  }
  *count = c;
  return score;
}

// Indices of the errors below `threshold_sq`.
void IndicesBelow(const std::vector<double>& err, double threshold_sq, std::vector<int>* out) {
  out->clear();
  for (size_t i = 0; i < err.size(); ++i) {
    if (err[i] < threshold_sq) out->push_back(static_cast<int>(i));
  }
}

// LO-RANSAC's local optimization of `model` (see RansacOptions): least-squares fits on its
// inliers and on random subsets of them, each iterated with a shrinking threshold. `err` holds
// the model's errors on entry (it is overwritten). Returns true and updates model / score /
// count when a fit scores better.
bool LocalOptimize(int sample_size, double threshold_sq, const RansacOptions& o, const FitFn& fit,
                   const ErrorFn& errors, std::mt19937* rng, std::vector<double>* err,
                   Eigen::Matrix3d* model, double* score, int* count) {
  std::vector<int> inliers;
  IndicesBelow(*err, threshold_sq, &inliers);
  const auto m = static_cast<size_t>(sample_size);
  if (inliers.size() <= m) return false;
  // Inner samples: 7 m points (or half the inliers), as in LO+.
  const size_t inner_size = std::min(inliers.size() / 2, 7 * m);
  bool improved = false;
  std::vector<int> subset, current;
  for (int inner = 0; inner <= o.lo_inner_samples; ++inner) {
    if (inner == 0) {
      subset = inliers;
    } else {
      if (inner_size <= m) break;
      subset = inliers;
      for (size_t k = 0; k < inner_size; ++k) {  // Partial Fisher-Yates shuffle.
        std::uniform_int_distribution<size_t> pick(k, subset.size() - 1);
        std::swap(subset[k], subset[pick(*rng)]);
      }
      subset.resize(inner_size);
    }
    std::optional<Eigen::Matrix3d> fitted = fit(subset);
    if (!fitted) continue;
    for (int step = 0; step < o.lo_steps; ++step) {
      const double mult =
          o.lo_steps > 1 ? o.lo_threshold_multiplier -
                               (o.lo_threshold_multiplier - 1.0) * step / (o.lo_steps - 1)
                         : 1.0;
      errors(*fitted, err);
      IndicesBelow(*err, mult * mult * threshold_sq, &current);
      if (current.size() <= m) break;
      std::optional<Eigen::Matrix3d> next = fit(current);
      if (!next) break;
      fitted = next;
    }
    errors(*fitted, err);
    int c = 0;
    const double s = MsacScore(*err, threshold_sq, &c);
    if (s < *score) {
      *score = s;
      *model = *fitted;
      *count = c;
      improved = true;
    }
  }
  return improved;
}

// Generic RANSAC with the MSAC score, adaptive N, optional LO.
RansacResult RunRansac(size_t n, int sample_size, double threshold_sq, const RansacOptions& o,
                       const FitFn& fit, const ErrorFn& errors) {
  RansacResult result;
  if (static_cast<int>(n) < sample_size) {
    result.failure_reason = "too few correspondences (" + std::to_string(n) + ")";
    return result;
  }
  std::mt19937 rng(o.seed);
  std::mt19937 lo_rng(o.seed ^ 0x9e3779b9u);  // LO draws do not shift the main samples.
  std::uniform_int_distribution<int> pick(0, static_cast<int>(n) - 1);
  std::vector<int> sample(static_cast<size_t>(sample_size));
  std::vector<double> err(n);
  double best_score = std::numeric_limits<double>::infinity();
  int required = o.max_iterations;
  bool found = false;
  int iteration = 0;
  for (; iteration < std::max(required, o.min_iterations) && iteration < o.max_iterations;
       ++iteration) {
    for (int k = 0; k < sample_size; ++k) {
      int idx;
      do {
        idx = pick(rng);
      } while (std::find(sample.begin(), sample.begin() + k, idx) != sample.begin() + k);
      sample[static_cast<size_t>(k)] = idx;
    }
    const std::optional<Eigen::Matrix3d> model = fit(sample);
    if (!model) continue;
    errors(*model, &err);
    int count = 0;
    double score = MsacScore(err, threshold_sq, &count);
    if (score < best_score) {
      Eigen::Matrix3d best = *model;
      if (o.local_optimization) {
        ++result.local_optimizations;
        if (LocalOptimize(sample_size, threshold_sq, o, fit, errors, &lo_rng, &err, &best, &score,
                          &count)) {
          ++result.local_improvements;
        }
      }
      best_score = score;
      result.model = best;
      result.num_inliers_minimal = count;
      found = true;
      required = RequiredIterations(static_cast<double>(count) / static_cast<double>(n),
                                    sample_size, o.confidence, o.max_iterations);
    }
  }
  result.iterations = iteration;
  result.required_iterations = required;
  if (!found) {
    result.failure_reason = "no non-degenerate minimal sample";
    return result;
  }
  result.success = true;
  return result;
}

void CollectInliers(const std::vector<double>& err, double threshold_sq, RansacResult* r) {
  r->inliers.clear();
  double sum = 0;
  for (size_t i = 0; i < err.size(); ++i) {
    if (err[i] < threshold_sq) {
      r->inliers.push_back(static_cast<int>(i));
      sum += err[i];
    }
  }
  r->inlier_rms_px =
      r->inliers.empty() ? 0.0 : std::sqrt(sum / static_cast<double>(r->inliers.size()));
}

}  // namespace

std::string RansacOptions::Check() const {
  if (!(threshold_px > 0)) return "threshold_px: must be > 0";
  if (!(confidence > 0 && confidence < 1)) return "confidence: must be in (0, 1)";
  if (max_iterations < 1) return "max_iterations: must be >= 1";
  if (min_iterations < 0 || min_iterations > max_iterations) {
    return "min_iterations: must be in [0, max_iterations]";
  }
  if (refine_iterations < 0) return "refine_iterations: must be >= 0";
  if (lo_inner_samples < 0) return "lo_inner_samples: must be >= 0";
  if (lo_steps < 1) return "lo_steps: must be >= 1";
  if (!(lo_threshold_multiplier >= 1)) return "lo_threshold_multiplier: must be >= 1";
  return {};
}

std::string CheiralityOptions::Check() const {
  if (!(max_runner_up_ratio > 0 && max_runner_up_ratio <= 1)) {
    return "max_runner_up_ratio: must be in (0, 1]";
  }
  return {};
}

std::string ClassifyOptions::Check() const {
  if (!(min_median_flow_px >= 0)) return "min_median_flow_px: must be >= 0";
  if (!(homography_share > 0 && homography_share <= 1)) return "homography_share: in (0, 1]";
  if (!(max_rotation_deviation > 0)) return "max_rotation_deviation: must be > 0";
  if (!(homography_threshold_px > 0)) return "homography_threshold_px: must be > 0";
  return {};
}

std::optional<Eigen::Matrix3d> EightPointFundamental(Points2 a, Points2 b) {
  if (a.size() != b.size()) return std::nullopt;
  const std::vector<int> all = AllIndices(a.size());
  return EightPointOnSubset(a, b, all);
}

double SampsonDistanceSq(const Eigen::Matrix3d& f, const Eigen::Vector2d& a,
                         const Eigen::Vector2d& b) {
  const double d = Sampson(f, a, b);
  return d * d;
}

std::optional<Eigen::Matrix3d> DltHomography(Points2 a, Points2 b) {
  if (a.size() != b.size()) return std::nullopt;
  const std::vector<int> all = AllIndices(a.size());
  return DltOnSubset(a, b, all);
}

double SymmetricTransferErrorSq(const Eigen::Matrix3d& h, const Eigen::Matrix3d& h_inv,
                                const Eigen::Vector2d& a, const Eigen::Vector2d& b) {
  const Eigen::Vector3d ha = h * a.homogeneous();
  const Eigen::Vector3d hb = h_inv * b.homogeneous();
  if (std::abs(ha.z()) < 1e-12 || std::abs(hb.z()) < 1e-12) {
    return std::numeric_limits<double>::infinity();
  }
  return (ha.hnormalized() - b).squaredNorm() + (hb.hnormalized() - a).squaredNorm();
}

Eigen::Matrix3d RefineFundamentalSampson(const Eigen::Matrix3d& f, Points2 a, Points2 b,
                                         std::span<const int> inliers, int max_iterations) {
  const int n = static_cast<int>(inliers.size());
  if (n < 8 || max_iterations <= 0) return f;
  // Work in Hartley-normalized coordinates so the 9 entries are of similar magnitude.
  const Eigen::Matrix3d ta = NormalizingTransform(a, inliers);
  const Eigen::Matrix3d tb = NormalizingTransform(b, inliers);
  std::vector<Eigen::Vector2d> na, nb;
  na.reserve(inliers.size());
  nb.reserve(inliers.size());
  for (int i : inliers) {
    na.push_back((ta * a[static_cast<size_t>(i)].homogeneous()).hnormalized());
    nb.push_back((tb * b[static_cast<size_t>(i)].homogeneous()).hnormalized());
  }
  Eigen::Matrix3d fn = tb.transpose().inverse() * f * ta.inverse();
  fn /= fn.norm();
  auto residuals = [&](const Eigen::Matrix3d& m) {
    Eigen::VectorXd r(n);
    for (int k = 0; k < n; ++k) {
      r[k] = Sampson(m, na[static_cast<size_t>(k)], nb[static_cast<size_t>(k)]);
    }
    return r;
  };
  Eigen::VectorXd res = residuals(fn);
  double cost = res.squaredNorm();
  double lambda = 1e-3;
  Eigen::MatrixXd jac(n, 9);
  for (int it = 0; it < max_iterations; ++it) {
    const double h = 1e-7;
    for (int j = 0; j < 9; ++j) {
      Eigen::Matrix3d fp = fn, fm = fn;
      fp(j / 3, j % 3) += h;
      fm(j / 3, j % 3) -= h;
      jac.col(j) = (residuals(fp) - residuals(fm)) / (2 * h);
    }
    const Eigen::Matrix<double, 9, 9> jtj = jac.transpose() * jac;
    const Eigen::Matrix<double, 9, 1> jtr = jac.transpose() * res;
    bool improved = false;
    bool converged = false;
    for (int tries = 0; tries < 8 && !improved; ++tries) {
      Eigen::Matrix<double, 9, 9> aug = jtj;
      aug.diagonal() += lambda * (jtj.diagonal().array() + 1e-12).matrix();
      const Eigen::Matrix<double, 9, 1> step = aug.ldlt().solve(-jtr);
      Eigen::Matrix3d cand = fn;
      for (int j = 0; j < 9; ++j) cand(j / 3, j % 3) += step[j];
      cand = EnforceRank2(cand);
      const Eigen::VectorXd res_new = residuals(cand);
      const double cost_new = res_new.squaredNorm();
      if (cost_new < cost) {
        converged = cost - cost_new < 1e-10 * cost;
        fn = cand;
        res = res_new;
        cost = cost_new;
        lambda = std::max(lambda * 0.1, 1e-9);
        improved = true;
      } else {
        lambda *= 10;
      }
    }
    if (!improved || converged) break;
  }
  const Eigen::Matrix3d out = tb.transpose() * fn * ta;
  return out / out.norm();
}

RansacResult RansacFundamental(Points2 a, Points2 b, const RansacOptions& options) {
  const double t2 = options.threshold_px * options.threshold_px;
  auto errors = [&](const Eigen::Matrix3d& f, std::vector<double>* e) {
    for (size_t i = 0; i < a.size(); ++i) (*e)[i] = SampsonDistanceSq(f, a[i], b[i]);
  };
  if (a.size() != b.size()) {
    RansacResult r;
    r.failure_reason = "correspondence count mismatch";
    return r;
  }
  RansacResult r = RunRansac(
      a.size(), 8, t2, options,
      [&](std::span<const int> s) { return EightPointOnSubset(a, b, s); }, errors);
  if (!r.success) return r;
  std::vector<double> err(a.size());
  errors(r.model, &err);
  CollectInliers(err, t2, &r);
  // Refit on all inliers (8-point), then LM on Sampson; take the inliers again each time.
  for (int round = 0; round < 2 && options.refine_iterations > 0; ++round) {
    if (r.inliers.size() < 8) break;
    const Eigen::Matrix3d refined =
        RefineFundamentalSampson(r.model, a, b, r.inliers, options.refine_iterations);
    errors(refined, &err);
    RansacResult candidate = r;
    candidate.model = refined;
    CollectInliers(err, t2, &candidate);
    if (candidate.inliers.size() + 2 < r.inliers.size()) break;  // Refinement drifted.
    r = std::move(candidate);
  }
  if (r.inliers.size() < 8) {
    r.success = false;
    r.failure_reason = "fewer than 8 inliers for F";
  }
  return r;
}

RansacResult RansacHomography(Points2 a, Points2 b, const RansacOptions& options) {
  // Inlier: symmetric transfer error below 2 t^2 (about t in each direction).
  const double t2 = 2.0 * options.threshold_px * options.threshold_px;
  auto errors = [&](const Eigen::Matrix3d& h, std::vector<double>* e) {
    const Eigen::Matrix3d h_inv = h.inverse();
    for (size_t i = 0; i < a.size(); ++i) (*e)[i] = SymmetricTransferErrorSq(h, h_inv, a[i], b[i]);
  };
  if (a.size() != b.size()) {
    RansacResult r;
    r.failure_reason = "correspondence count mismatch";
    return r;
  }
  RansacResult r = RunRansac(
      a.size(), 4, t2, options, [&](std::span<const int> s) { return DltOnSubset(a, b, s); },
      errors);
  if (!r.success) return r;
  std::vector<double> err(a.size());
  errors(r.model, &err);
  CollectInliers(err, t2, &r);
  if (r.inliers.size() >= 4) {
    if (const auto refit = DltOnSubset(a, b, r.inliers)) {
      errors(*refit, &err);
      RansacResult candidate = r;
      candidate.model = *refit;
      CollectInliers(err, t2, &candidate);
      if (candidate.inliers.size() >= r.inliers.size()) r = std::move(candidate);
    }
  }
  return r;
}

Eigen::Matrix3d EssentialFromFundamental(const Eigen::Matrix3d& f, const Eigen::Matrix3d& k) {
  const Eigen::Matrix3d e = k.transpose() * f * k;
  Eigen::JacobiSVD<Eigen::Matrix3d> svd(e, Eigen::ComputeFullU | Eigen::ComputeFullV);
  const Eigen::Matrix3d out =
      svd.matrixU() * Eigen::Vector3d(1, 1, 0).asDiagonal() * svd.matrixV().transpose();
  return out / out.norm();
}

std::array<RelativePose, 4> DecomposeEssential(const Eigen::Matrix3d& e) {
  Eigen::JacobiSVD<Eigen::Matrix3d> svd(e, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d u = svd.matrixU();
  Eigen::Matrix3d v = svd.matrixV();
  if (u.determinant() < 0) u = -u;
  if (v.determinant() < 0) v = -v;
  Eigen::Matrix3d w;
  w << 0, -1, 0, 1, 0, 0, 0, 0, 1;
  const Eigen::Matrix3d r1 = u * w * v.transpose();
  const Eigen::Matrix3d r2 = u * w.transpose() * v.transpose();
  const Eigen::Vector3d t = u.col(2).normalized();
  return {RelativePose{r1, t}, RelativePose{r1, -t}, RelativePose{r2, t}, RelativePose{r2, -t}};
}

Eigen::Vector3d TriangulateLinear(const Eigen::Vector2d& x_a, const Eigen::Vector2d& x_b,
                                  const RelativePose& pose) {
  Eigen::Matrix<double, 3, 4> p_b;
  p_b << pose.rotation, pose.translation;
  Eigen::Matrix4d m;
  m.row(0) << -1, 0, x_a.x(), 0;
  m.row(1) << 0, -1, x_a.y(), 0;
  m.row(2) = x_b.x() * p_b.row(2) - p_b.row(0);
  m.row(3) = x_b.y() * p_b.row(2) - p_b.row(1);
  const Eigen::JacobiSVD<Eigen::Matrix4d> svd(m, Eigen::ComputeFullV);
  const Eigen::Vector4d x = svd.matrixV().col(3);
  return x.head<3>() / x.w();
}

Eigen::Vector3d RefineTriangulation(const Eigen::Vector3d& initial, const Eigen::Vector2d& x_a,
                                    const Eigen::Vector2d& x_b, const RelativePose& pose,
                                    int iterations) {
  Eigen::Vector3d p = initial;
  if (!p.allFinite()) return initial;
  for (int it = 0; it < iterations; ++it) {
    const Eigen::Vector3d q = pose.rotation * p + pose.translation;
    if (p.z() <= 1e-12 || q.z() <= 1e-12) break;
    Eigen::Matrix<double, 4, 1> r;
    r.head<2>() = p.hnormalized() - x_a;
    r.tail<2>() = q.hnormalized() - x_b;
    Eigen::Matrix<double, 4, 3> j;
    Eigen::Matrix<double, 2, 3> ja, jb;
    ja << 1 / p.z(), 0, -p.x() / (p.z() * p.z()), 0, 1 / p.z(), -p.y() / (p.z() * p.z());
    jb << 1 / q.z(), 0, -q.x() / (q.z() * q.z()), 0, 1 / q.z(), -q.y() / (q.z() * q.z());
    j.topRows<2>() = ja;
    j.bottomRows<2>() = jb * pose.rotation;
    const Eigen::Vector3d step = (j.transpose() * j).ldlt().solve(-j.transpose() * r);
    if (!step.allFinite()) break;
    p += step;
    if (step.norm() < 1e-12 * p.norm()) break;
  }
  return p.allFinite() ? p : initial;
}

Eigen::Vector2d ReprojectionErrorsPx(const Eigen::Matrix3d& k, const Eigen::Vector3d& p_a,
                                     const Eigen::Vector3d& p_b, const Eigen::Vector2d& pixel_a,
                                     const Eigen::Vector2d& pixel_b) {
  return {((k * p_a).hnormalized() - pixel_a).norm(), ((k * p_b).hnormalized() - pixel_b).norm()};
}

double TriangulationAngleDeg(const Eigen::Vector3d& p_a, const RelativePose& pose) {
  const Eigen::Vector3d center_b = -pose.rotation.transpose() * pose.translation;
  const double c = p_a.normalized().dot((p_a - center_b).normalized());
  return std::acos(std::clamp(c, -1.0, 1.0)) * 180.0 / std::numbers::pi;
}

CheiralityResult SelectPoseByCheirality(const Eigen::Matrix3d& e, Points2 norm_a, Points2 norm_b,
                                        std::span<const int> inliers,
                                        const CheiralityOptions& options) {
  CheiralityResult out;
  const std::array<RelativePose, 4> poses = DecomposeEssential(e);
  for (int c = 0; c < 4; ++c) {
    const RelativePose& pose = poses[static_cast<size_t>(c)];
    int count = 0;
    for (int i : inliers) {
      // Depths along both rays by least squares: z_b d_b = z_a R d_a + t (2 unknowns).
      const Eigen::Vector3d da = norm_a[static_cast<size_t>(i)].homogeneous();
      const Eigen::Vector3d db = norm_b[static_cast<size_t>(i)].homogeneous();
      const Eigen::Vector3d rda = pose.rotation * da;
      Eigen::Matrix<double, 3, 2> m;
      m << rda, -db;
      const Eigen::Matrix2d mtm = m.transpose() * m;
      const double det = mtm.determinant();
      if (std::abs(det) < 1e-14) continue;
      const Eigen::Vector2d z = mtm.inverse() * (m.transpose() * -pose.translation);
      if (z[0] > 0 && z[1] > 0) ++count;
    }
    out.in_front[static_cast<size_t>(c)] = count;
  }
  std::array<int, 4> order{0, 1, 2, 3};
  std::sort(order.begin(), order.end(),
            [&](int x, int y) { return out.in_front[static_cast<size_t>(x)] >
                                       out.in_front[static_cast<size_t>(y)]; });
  const int best = out.in_front[static_cast<size_t>(order[0])];
  const int second = out.in_front[static_cast<size_t>(order[1])];
  out.winner = order[0];
  out.pose = poses[static_cast<size_t>(order[0])];
  if (best == 0) {
    out.failure_reason = "cheirality: no pose puts points in front of both cameras";
    return out;
  }
  if (second > options.max_runner_up_ratio * best) {
    out.failure_reason = "cheirality: no clear winner (" + std::to_string(best) + " vs " +
                         std::to_string(second) + " points in front)";
    return out;
  }
  out.success = true;
  return out;
}

const char* PairKindName(PairKind kind) {
  switch (kind) {
    case PairKind::kGeneral:
      return "general";
    case PairKind::kPlanar:
      return "planar";
    case PairKind::kRotation:
      return "rotation";
    case PairKind::kNoParallax:
      return "no_parallax";
  }
  return "unknown";
}

PairClassification ClassifyPair(Points2 a, Points2 b, const RansacResult& f,
                                const RansacResult& h, const Eigen::Matrix3d& k,
                                const ClassifyOptions& options) {
  PairClassification c;
  std::vector<double> flow;
  flow.reserve(a.size());
  for (size_t i = 0; i < a.size() && i < b.size(); ++i) flow.push_back((b[i] - a[i]).norm());
  c.median_flow_px = MedianOf(flow);
  c.f_inliers = f.success ? static_cast<int>(f.inliers.size()) : 0;
  c.h_inliers = h.success ? static_cast<int>(h.inliers.size()) : 0;
  c.h_share = c.f_inliers > 0 ? static_cast<double>(c.h_inliers) / c.f_inliers : 0.0;
  if (h.success) {
    const Eigen::Matrix3d m = k.inverse() * h.model * k;
    const Eigen::Vector3d s = Eigen::JacobiSVD<Eigen::Matrix3d>(m).singularValues();
    c.rotation_deviation = s[0] > 0 ? 1.0 - s[2] / s[0] : 1.0;
  }
  if (c.median_flow_px < options.min_median_flow_px) {
    c.kind = PairKind::kNoParallax;
    c.explanation = "no parallax: median image motion " + std::to_string(c.median_flow_px) +
                    " px";
  } else if (h.success && c.h_share > options.homography_share) {
    if (c.rotation_deviation < options.max_rotation_deviation) {
      c.kind = PairKind::kRotation;
      c.explanation = "pure rotation: a homography explains " + std::to_string(c.h_inliers) +
                      " of " + std::to_string(c.f_inliers) + " inliers and K^-1 H K is a rotation";
    } else {
      c.kind = PairKind::kPlanar;
      c.explanation = "planar scene: a homography explains " + std::to_string(c.h_inliers) +
                      " of " + std::to_string(c.f_inliers) + " inliers (F is ill-conditioned)";
    }
  } else {
    c.kind = PairKind::kGeneral;
  }
  return c;
}

}  // namespace mm
