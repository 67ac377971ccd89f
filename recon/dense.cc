#include "recon/dense.h"

#include "base/stats.h"
#include "recon/depth_filters.h"
#include "recon/plane_warp.h"
#include "recon/sgm.h"
#include "recon/zncc.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>
#include <vector>

namespace mm {
namespace {

// Costs are (1 - ZNCC) in fixed point: 0..2 -> 0..2 * kCostScale. With eight paths the
// aggregated sum stays below 8 * (2 kCostScale + P2) < 2^16.
constexpr int kCostScale = 64;
constexpr uint16_t kNeutralCost = kCostScale;  // ZNCC 0: no information.
constexpr uint16_t kUnseen = 0xFFFF;           // No view has a cost yet.

struct ViewInShrunkA {
  cv::Mat image;  // CV_32F, shrunk.
  Eigen::Matrix3d rotation;
  Eigen::Vector3d translation;
};

// The camera matrix of an image shrunk by `f` (pixel centres: u_s = (u + 0.5) / f - 0.5).
Eigen::Matrix3d ShrinkK(const Eigen::Matrix3d& K, int f) {
  Eigen::Matrix3d S = Eigen::Matrix3d::Identity();
  S(0, 0) = S(1, 1) = 1.0 / f;
  S(0, 2) = S(1, 2) = 0.5 / f - 0.5;
  return S * K;
}

// The homography taking A's pixels to B's for the plane z_a = 1 / rho (x_b = R x_a + t).
Eigen::Matrix3d PlaneHomography(const Eigen::Matrix3d& K, const Eigen::Matrix3d& K_inv,
                                const Eigen::Matrix3d& R, const Eigen::Vector3d& t, double rho) {
  Eigen::Matrix3d M = R;
  M.col(2) += t * rho;
  return K * M * K_inv;
}

// How far the sweep's range moves a pixel of A in the view (x_view = R x_a + t): the
// largest displacement between the nearest and the farthest plane over a 5x5 grid of A.
double SweepSpanPx(const Eigen::Matrix3d& Ks, const Eigen::Matrix3d& Ks_inv,
                   const Eigen::Matrix3d& R, const Eigen::Vector3d& t, double rho_min,
                   double rho_max, cv::Size size) {
  double span = 0;
  for (int gy = 0; gy <= 4; ++gy) {
    for (int gx = 0; gx <= 4; ++gx) {
      const Eigen::Vector3d ray =
          Ks_inv * Eigen::Vector3d(gx * (size.width - 1) / 4.0, gy * (size.height - 1) / 4.0, 1.0);
      const Eigen::Vector3d near_view = Ks * (R * ray + t * rho_max);
      const Eigen::Vector3d far_view = Ks * (R * ray + t * rho_min);
      if (near_view.z() <= 0 || far_view.z() <= 0) continue;
      span = std::max(span, (near_view.hnormalized() - far_view.hnormalized()).norm());
    }
  }
  return span;
}

// 1 - ZNCC (fixed point, 0..2 kCostScale) of A's windows against the view warped into A by the
// plane's homography H (A's pixels to the view's), for every pixel of A (recon/zncc.h). A
// warped window without texture gets ZNCC 0. `warped`: scratch of A's size (CV_32F).
void PlaneCost(const ZnccWindowsA& windows_a, const cv::Mat& view, const Eigen::Matrix3d& H,
               float min_var, cv::Mat* warped, cv::Mat* cost) {
  const size_t pixels = warped->total();
  CV_Assert(view.isContinuous() && view.size() == warped->size());
  const bool warped_ok =
      WarpByHomography(std::span<const float>(view.ptr<float>(), pixels), view.cols, view.rows, H,
                       std::span<float>(warped->ptr<float>(), pixels));
  const bool cost_ok =
      PlaneZnccCost(windows_a, std::span<const float>(warped->ptr<float>(), pixels), min_var,
                    kCostScale, std::span<uint16_t>(cost->ptr<uint16_t>(), pixels));
  CV_Assert(warped_ok && cost_ok);  // The sizes are the sweep's own.
}

// Adds one view's plane costs to the plane's slice of the volume (plane-major) at A's textured
// pixels that the view sees under H: the first view's (B's) cost as it is; a further view's,
// where B has one, as their mean while they differ by at most `cap`, else as the better one's
// plus cap / 2 (DenseOptions::max_view_disagreement).
void AccumulatePlaneCost(const cv::Mat& cost, const Eigen::Matrix3d& H, const cv::Mat& textured,
                         int cap, uint16_t* plane) {
  const int width = cost.cols, height = cost.rows;
  const auto cap_f = static_cast<float>(cap);
  const Eigen::Vector3d dh = H.col(0);
  for (int y = 0; y < height; ++y) {
    const uint8_t* tex = textured.ptr<uint8_t>(y);
    const uint16_t* c_row = cost.ptr<uint16_t>(y);
    uint16_t* out_row = plane + static_cast<size_t>(y) * width;
    // The row's pixels the view sees: its homogeneous pixel h(x) = H (x, y, 1) has z > 0 and
    // 0 <= u, v <= size - 1, each an affine inequality c0 + c1 x >= 0, so an interval of x.
    const Eigen::Vector3d h0 = H * Eigen::Vector3d(0, y, 1);
    double lo = 0, hi = width - 1;
    auto require = [&lo, &hi](double c0, double c1) {
      if (c1 > 0) {
        lo = std::max(lo, -c0 / c1);
      } else if (c1 < 0) {
        hi = std::min(hi, -c0 / c1);
      } else if (c0 < 0) {
        hi = -1;
      }
    };
    require(h0.z() - 1e-9, dh.z());
    require(h0.x(), dh.x());
    require((width - 1) * h0.z() - h0.x(), (width - 1) * dh.z() - dh.x());
    require(h0.y(), dh.y());
    require((height - 1) * h0.z() - h0.y(), (height - 1) * dh.z() - dh.y());
    const int x0 = static_cast<int>(std::ceil(lo)), x1 = static_cast<int>(std::floor(hi));
    for (int x = x0; x <= x1; ++x) {
      if (!tex[x]) continue;
      const uint16_t c = c_row[x];
      uint16_t& o = out_row[x];
      if (o == kUnseen) {
        o = c;
      } else {
        // Their mean where they agree within the cap, else the better one plus half the cap.
        const float diff = std::abs(static_cast<float>(c) - static_cast<float>(o));
        o = static_cast<uint16_t>(static_cast<float>(std::min(o, c)) +
                                  0.5f * std::min(diff, cap_f) + 0.5f);
      }
    }
  }
}

}  // namespace

std::string DenseOptions::Check() const {
  if (downscale < 1 || downscale > 8) return "dense.downscale must be in [1, 8]";
  if (window_radius < 1 || window_radius > 10) return "dense.window_radius must be in [1, 10]";
  if (!(plane_step_px > 0.1 && plane_step_px <= 10))
    return "dense.plane_step_px must be in (0.1, 10]";
  if (min_planes < 3 || max_planes < min_planes || max_planes > 256) {
    return "dense.min_planes / max_planes must satisfy 3 <= min <= max <= 256";
  }
  if (!(near_margin >= 1 && near_margin <= 10) || !(far_margin >= 1 && far_margin <= 100)) {
    return "dense.near_margin must be in [1, 10] and dense.far_margin in [1, 100]";
  }
  if (!(penalty_small >= 0 && penalty_large >= penalty_small && penalty_large <= 2)) {
    return "dense penalties must satisfy 0 <= penalty_small <= penalty_large <= 2";
  }
  if (edge_tau < 0 || edge_tau > 255) return "dense.edge_tau must be in [0, 255]";
  if (!(min_texture_std >= 0 && min_texture_std < 128))
    return "dense.min_texture_std must be in [0, 128)";
  if (!(min_zncc >= -1 && min_zncc <= 1)) return "dense.min_zncc must be in [-1, 1]";
  if (!(min_confidence >= 0 && min_confidence < 1)) return "dense.min_confidence must be in [0, 1)";
  if (!(max_speckle_fraction >= 0 && max_speckle_fraction < 1)) {
    return "dense.max_speckle_fraction must be in [0, 1)";
  }
  if (speckle_planes < 0 || speckle_planes > 16) return "dense.speckle_planes must be in [0, 16]";
  if (!(max_view_disagreement >= 0 && max_view_disagreement <= 2)) {
    return "dense.max_view_disagreement must be in [0, 2]";
  }
  if (occlusion_band_px < 0 || occlusion_band_px > 64) {
    return "dense.occlusion_band_px must be in [0, 64]";
  }
  if (edge_snap_min_step < 0 || edge_snap_min_step > 255) {
    return "dense.edge_snap_min_step must be in [0, 255]";
  }
  if (!(max_hole_fraction >= 0 && max_hole_fraction < 1)) {
    return "dense.max_hole_fraction must be in [0, 1)";
  }
  return {};
}

DenseDepth ComputeDenseDepth(const cv::Mat& gray_a, const cv::Mat& gray_b, const Eigen::Matrix3d& K,
                             const Eigen::Matrix3d& rotation_b_from_a,
                             const Eigen::Vector3d& translation_b_from_a,
                             std::span<const Eigen::Vector3d> sparse_points_in_cam_a,
                             const DenseOptions& options, std::span<const DenseView> extra_views) {
  DenseDepth out;
  if (const std::string error = options.Check(); !error.empty()) {
    out.failure_reason = error;
    return out;
  }
  if (gray_a.empty() || gray_a.type() != CV_8UC1 || gray_b.type() != CV_8UC1 ||
      gray_a.size() != gray_b.size()) {
    out.failure_reason = "dense: keyframes must be 8-bit grey images of one size";
    return out;
  }
  std::vector<double> rhos;
  for (const Eigen::Vector3d& p : sparse_points_in_cam_a) {
    if (p.z() > 0 && std::isfinite(p.z())) rhos.push_back(1.0 / p.z());
  }
  if (rhos.size() < 10) {
    out.failure_reason = "dense: fewer than 10 sparse points in front of A for the depth range";
    return out;
  }
  const double rho_max = QuantileOf(rhos, 0.98) * options.near_margin;
  const double rho_min = QuantileOf(rhos, 0.02) / options.far_margin;

  // Shrunk images and camera.
  const int f = options.downscale;
  cv::Mat a8 = gray_a, b8 = gray_b;
  if (f > 1) {
    const cv::Size size(gray_a.cols / f, gray_a.rows / f);
    cv::resize(gray_a, a8, size, 0, 0, cv::INTER_AREA);
    cv::resize(gray_b, b8, size, 0, 0, cv::INTER_AREA);
  }
  const int width = a8.cols, height = a8.rows;
  const int r = options.window_radius;
  if (width < 4 * r + 2 || height < 4 * r + 2) {
    out.failure_reason = "dense: image too small for the window";
    return out;
  }
  const Eigen::Matrix3d Ks = ShrinkK(K, f);
  const Eigen::Matrix3d Ks_inv = Ks.inverse();
  const Eigen::Matrix3d& R = rotation_b_from_a;
  const Eigen::Vector3d& t = translation_b_from_a;

  // Planes: enough that neighbouring ones move A's pixels by about plane_step_px in B.
  const double span = SweepSpanPx(Ks, Ks_inv, R, t, rho_min, rho_max, a8.size());
  const int planes = std::clamp(static_cast<int>(std::ceil(span / options.plane_step_px)) + 1,
                                options.min_planes, options.max_planes);
  const double rho_step = (rho_max - rho_min) / (planes - 1);
  out.K = Ks;
  out.downscale = f;
  out.inverse_depth_min = rho_min;
  out.inverse_depth_max = rho_max;
  out.planes = planes;
  out.inverse_depth_step = rho_step;

  // A's window statistics.
  cv::Mat a, b;
  a8.convertTo(a, CV_32F);
  b8.convertTo(b, CV_32F);
  const ZnccStatsA stats_a = ComputeZnccStatsA(a, r);
  const float min_var = static_cast<float>(options.min_texture_std * options.min_texture_std);
  const cv::Mat textured = stats_a.var_a >= min_var;  // 255 where textured.

  // Cost volume, filled plane by plane (plane-major, contiguous writes), then transposed in
  // cache-sized blocks to pixel-major for the aggregation: cost[(y * width + x) * planes + d].
  const size_t pixels = static_cast<size_t>(width) * height;
  // The volumes are kept per thread between calls: at 320x240 x 64 planes each is 10 MB, and
  // fresh pages for them cost more than the sweep itself (measured: 45 % of the stage). The
  // plane-major costs live in the sum's volume until the transpose.
  thread_local std::vector<uint16_t> cost, sum;
  std::vector<uint16_t>& cost_by_plane = sum;
  cost_by_plane.assign(pixels * planes, kUnseen);
  // B, then the further views: each view's cost is computed at every plane that moves a
  // pixel by about plane_step_px in it (B's sampling; a view nearer A moves pixels less, so
  // every k-th plane, linearly interpolated between), and combined into the volume.
  std::vector<ViewInShrunkA> views;
  views.push_back({b, R, t});
  for (const DenseView& view : extra_views) {
    cv::Mat v8 = view.gray, vf;
    if (f > 1) cv::resize(view.gray, v8, a8.size(), 0, 0, cv::INTER_AREA);
    v8.convertTo(vf, CV_32F);
    views.push_back({vf, view.rotation_from_a, view.translation_from_a});
  }
  const int disagreement_cap =
      static_cast<int>(std::lround(options.max_view_disagreement * kCostScale));
  const ZnccWindowsA windows_a = stats_a.Windows();
  cv::Mat warped(a.size(), CV_32F);
  cv::Mat previous_cost(a.size(), CV_16U), current_cost(a.size(), CV_16U);
  cv::Mat blended_cost(a.size(), CV_16U);
  for (size_t v = 0; v < views.size(); ++v) {
    const ViewInShrunkA& view = views[v];
    auto homography = [&](int d) {
      return PlaneHomography(Ks, Ks_inv, view.rotation, view.translation, rho_min + d * rho_step);
    };
    int stride = 1;
    if (v > 0) {
      const double view_span =
          SweepSpanPx(Ks, Ks_inv, view.rotation, view.translation, rho_min, rho_max, a.size());
      const int view_planes = static_cast<int>(std::ceil(view_span / options.plane_step_px)) + 1;
      stride = std::max(1, (planes - 1) / std::max(1, view_planes - 1));
    }
    auto accumulate = [&](int d, const cv::Mat& plane_cost) {
      AccumulatePlaneCost(plane_cost, homography(d), textured, disagreement_cap,
                          &cost_by_plane[static_cast<size_t>(d) * pixels]);
    };
    int previous_d = -1;
    for (int d = 0; d < planes; d = (d == planes - 1) ? planes : std::min(d + stride, planes - 1)) {
      PlaneCost(windows_a, view.image, homography(d), min_var, &warped, &current_cost);
      for (int between = previous_d + 1; previous_d >= 0 && between < d; ++between) {
        const double w = static_cast<double>(between - previous_d) / (d - previous_d);
        cv::addWeighted(previous_cost, 1.0 - w, current_cost, w, 0.0, blended_cost, CV_16U);
        accumulate(between, blended_cost);
      }
      accumulate(d, current_cost);
      std::swap(previous_cost, current_cost);
      previous_d = d;
    }
  }
  std::replace(cost_by_plane.begin(), cost_by_plane.end(), kUnseen, kNeutralCost);
  cost.resize(pixels * planes);
  constexpr size_t kBlock = 64;
  for (size_t p0 = 0; p0 < pixels; p0 += kBlock) {
    const size_t p1 = std::min(pixels, p0 + kBlock);
    for (int d = 0; d < planes; ++d) {
      const uint16_t* src = &cost_by_plane[static_cast<size_t>(d) * pixels];
      for (size_t p = p0; p < p1; ++p) cost[p * planes + d] = src[p];
    }
  }

  // Semi-global aggregation over eight paths.
  SgmPenalties penalties;
  penalties.p1 = static_cast<uint16_t>(std::lround(options.penalty_small * kCostScale));
  penalties.p2 =
      std::max<uint16_t>(static_cast<uint16_t>(penalties.p1 + 1),
                         static_cast<uint16_t>(std::lround(options.penalty_large * kCostScale)));
  penalties.edge_tau = options.edge_tau;
  sum.assign(pixels * planes, 0);
  const cv::Mat guide = a8.isContinuous() ? a8 : a8.clone();
  if (!AggregateSgm(cost, std::span<const uint8_t>(guide.data, pixels), width, height, planes,
                    penalties, sum)) {
    out.failure_reason = "dense: the cost volume does not fit the aggregation's 16-bit sums";
    return out;
  }

  // Winner-take-all, the parabola through the minimum and its neighbours, the checks.
  cv::Mat plane_x16(height, width, CV_16SC1, cv::Scalar(-1));
  cv::Mat confidence(height, width, CV_32FC1, cv::Scalar(0));
  const int min_zncc_cost = static_cast<int>(std::lround((1.0 - options.min_zncc) * kCostScale));
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      const size_t p = static_cast<size_t>(y) * width + x;
      const uint16_t* s = &sum[p * planes];
      // Minimum, then its first index, then the minimum outside best +- 1 (each loop
      // vectorizes).
      uint16_t best_value = s[0];
      for (int d = 1; d < planes; ++d) best_value = std::min(best_value, s[d]);
      const int best = static_cast<int>(std::find(s, s + planes, best_value) - s);
      if (best == 0 || best == planes - 1) continue;  // Outside the swept range.
      int second = std::numeric_limits<int>::max();
      for (int d = 0; d < best - 1; ++d) second = std::min(second, static_cast<int>(s[d]));
      for (int d = best + 2; d < planes; ++d) second = std::min(second, static_cast<int>(s[d]));
      const double conf = second > 0 ? 1.0 - static_cast<double>(s[best]) / second : 0.0;
      if (conf < options.min_confidence) continue;
      if (textured.at<uint8_t>(y, x) && cost[p * planes + best] > min_zncc_cost) continue;
      const double s0 = s[best - 1], s1 = s[best], s2 = s[best + 1];
      const double denom = s0 - 2 * s1 + s2;
      const double offset = denom > 0 ? std::clamp(0.5 * (s0 - s2) / denom, -0.5, 0.5) : 0.0;
      plane_x16.at<int16_t>(y, x) = static_cast<int16_t>(std::lround(16 * (best + offset)));
      confidence.at<float>(y, x) = static_cast<float>(conf);
    }
  }
  if (options.max_speckle_fraction > 0) {
    cv::filterSpeckles(plane_x16, -1,
                       static_cast<int>(options.max_speckle_fraction * static_cast<double>(pixels)),
                       16 * options.speckle_planes);
  }
  cv::Mat rho(height, width, CV_32FC1, cv::Scalar(0));
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      const int16_t v = plane_x16.at<int16_t>(y, x);
      if (v < 0) {
        confidence.at<float>(y, x) = 0;
        continue;
      }
      rho.at<float>(y, x) = static_cast<float>(rho_min + rho_step * v / 16.0);
    }
  }
  out.inverse_depth = MedianOfValid(rho);
  out.cut_to_outlines = CutDepthEdgesToOutlines(a8, r, options.edge_snap_min_step, rho_step,
                                                &out.inverse_depth, &confidence);
  out.filled_in_holes = FillPlanarHoles(
      static_cast<int>(options.max_hole_fraction * static_cast<double>(pixels)),
      static_cast<float>(options.min_confidence), rho_step, &out.inverse_depth, &confidence);
  out.dropped_in_occlusion_bands =
      DropOcclusionBands(Ks_inv, -R.transpose() * t, options.occlusion_band_px, rho_step,
                         &out.inverse_depth, &confidence);
  out.confidence = confidence;
  const int valid = cv::countNonZero(out.inverse_depth > 0);
  out.valid_fraction = static_cast<double>(valid) / static_cast<double>(pixels);
  if (valid == 0) {
    out.failure_reason = "dense: no pixel has a confident depth";
    return out;
  }
  out.success = true;
  return out;
}

double InverseDepthAt(const DenseDepth& depth, double u, double v) {
  const cv::Mat& rho = depth.inverse_depth;
  if (rho.empty()) return 0;
  const double f = depth.downscale;
  const double us = (u + 0.5) / f - 0.5, vs = (v + 0.5) / f - 0.5;
  const int xn = static_cast<int>(std::lround(us)), yn = static_cast<int>(std::lround(vs));
  if (xn < 0 || yn < 0 || xn >= rho.cols || yn >= rho.rows) return 0;
  const float nearest = rho.at<float>(yn, xn);
  if (!(nearest > 0)) return 0;
  const int x0 = static_cast<int>(std::floor(us)), y0 = static_cast<int>(std::floor(vs));
  const double fx = us - x0, fy = vs - y0;
  double sum = 0, weight = 0;
  float lo = nearest, hi = nearest;
  for (int j = 0; j <= 1; ++j) {
    for (int i = 0; i <= 1; ++i) {
      const int x = x0 + i, y = y0 + j;
      if (x < 0 || y < 0 || x >= rho.cols || y >= rho.rows) continue;
      const float value = rho.at<float>(y, x);
      if (!(value > 0)) continue;
      const double w = (i ? fx : 1 - fx) * (j ? fy : 1 - fy);
      sum += w * value;
      weight += w;
      lo = std::min(lo, value);
      hi = std::max(hi, value);
    }
  }
  // Across a depth edge a blend would be a point on neither surface: take the nearest.
  if (IsDepthEdge(hi, lo, depth.inverse_depth_step)) return nearest;
  return weight > 1e-9 ? sum / weight : nearest;
}

}  // namespace mm
