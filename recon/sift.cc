// Our SIFT (Lowe, IJCV 2004) with OpenCV 4.6's scale space and keypoint convention; the
// per-pixel kernels are in recon/sift_kernels.cc (Highway). Differences from cv::SIFT, by
// design: keypoint positions map pixel centres exactly between octaves (OpenCV's doubled image
// puts them 0.25 px off), the descriptor grid is centred on the sub-pixel position (as VLFeat),
// gradients come from per-layer maps computed once (only for layers that hold keypoints), and
// atan2 / exp are polynomial approximations.

#include <Eigen/Dense>
#include <algorithm>
#include <array>
#include <cfloat>
#include <cmath>
#include <opencv2/imgproc.hpp>
#include <tuple>

#include "recon/sift.h"

namespace mm::sift {
namespace {

constexpr int kBorder = 5;          // SIFT_IMG_BORDER: no extrema this close to the edges.
constexpr int kMaxInterpSteps = 5;  // Lowe 2004 Sec. 4: re-centre at most this often.
constexpr float kInitSigma = 0.5f;  // Assumed blur of the input (Lowe 2004 Sec. 3.3).
constexpr int kOriBins = 36;        // Lowe 2004 Sec. 5.
constexpr float kOriPeakRatio = 0.8f;
constexpr float kOriSigmaFactor = 1.5f;
constexpr float kOriRadiusFactor = 3 * kOriSigmaFactor;
constexpr int kDescWidth = 4, kDescBins = 8;  // Lowe 2004 Sec. 6.1: 4x4 cells of 8 bins.
constexpr float kDescBinWidth = 3.0f;         // Cell width in units of the keypoint's sigma.
constexpr float kDescClamp = 0.2f;            // Lowe 2004 Sec. 6.1: illumination robustness.
constexpr float kDescScale = 512.0f;          // OpenCV's integer scaling (then saturate to u8).
constexpr double kEdgeThreshold = 10;         // Lowe 2004 Sec. 4.1: r = 10.
constexpr double kSigma = 1.6;

// A keypoint in its octave: integer sample (layer, r, c), sub-sample offset, orientation.
struct OctaveKeypoint {
  int octave = 0;  // Pyramid index (0 = first octave).
  int layer = 0;
  int r = 0, c = 0;
  float xc = 0, xr = 0, xi = 0;
  float response = 0;
  float angle = 0;  // OpenCV's convention: 360 - gradient direction (degrees).
  float scale = 0;  // Sigma in octave pixels.
};

// An OpenCV header over a plane's memory (rows contiguous), so cv:: functions read and write it
// in place (cv::Mat has no read-only header; sources are only read).
cv::Mat AsMat(const Plane& p) { return cv::Mat(p.h, p.w, CV_32F, const_cast<float*>(p.px.get())); }

// The 8-bit image as floats, at `scale` times its size: 2 (bilinear, OpenCV's INTER_LINEAR, as
// cv::SIFT doubles its input) or 1.
void ToPlane(const cv::Mat& gray, int scale, Plane* out) {
  out->Resize(gray.cols * scale, gray.rows * scale);
  if (scale == 1) {
    gray.convertTo(AsMat(*out), CV_32F);
    return;
  }
  cv::Mat f;
  gray.convertTo(f, CV_32F);
  cv::resize(f, AsMat(*out), AsMat(*out).size(), 0, 0, cv::INTER_LINEAR);
}

// Every other pixel (OpenCV's INTER_NEAREST halving): the next octave's first layer.
void Decimate(const Plane& src, Plane* out) {
  out->Resize(src.w / 2, src.h / 2);
  cv::resize(AsMat(src), AsMat(*out), AsMat(*out).size(), 0, 0, cv::INTER_NEAREST);
}

// Buffers kept per thread between calls: the pyramid of a 640x480 image with its doubled first
// octave is ~100 MB, and faulting it in afresh for every image cost ~15 % of the time.
struct Workspace {
  Plane input, base;
  std::vector<Plane> gauss, dog;
  std::vector<std::vector<Plane>> mags, oris;
  std::vector<int> candidates;
  DescriptorSamples samples;
};

// Lowe 2004 Sec. 4 (after Brown & Lowe 2002): fit a 3D quadratic to D around the sample, move
// to the neighbour while the offset exceeds 0.5 in any dimension, then reject low contrast
// (|D(x^)| * layers < threshold, OpenCV's scaling) and edges (Sec. 4.1, tr^2/det >= (r+1)^2/r).
bool Refine(const std::vector<Plane>& dog, int layers, double contrast_threshold,
            OctaveKeypoint* kp) {
  constexpr double kScale = 1.0 / 255, kD1 = 0.5 * kScale, kD2 = kScale, kDx = 0.25 * kScale;
  int layer = kp->layer, r = kp->r, c = kp->c;
  const int w = dog[0].w, h = dog[0].h;
  Eigen::Vector3d x = Eigen::Vector3d::Zero(), grad = Eigen::Vector3d::Zero();
  double dxx = 0, dyy = 0, dxy = 0;  // The 2-D Hessian at the final sample, for the edge test.
  int step = 0;
  for (; step < kMaxInterpSteps; ++step) {
    const Plane& img = dog[static_cast<size_t>(layer)];
    const Plane& prv = dog[static_cast<size_t>(layer - 1)];
    const Plane& nxt = dog[static_cast<size_t>(layer + 1)];
    grad << (img.At(r, c + 1) - img.At(r, c - 1)) * kD1,
        (img.At(r + 1, c) - img.At(r - 1, c)) * kD1, (nxt.At(r, c) - prv.At(r, c)) * kD1;
    const double v2 = img.At(r, c) * 2.0;
    dxx = (img.At(r, c + 1) + img.At(r, c - 1) - v2) * kD2;
    dyy = (img.At(r + 1, c) + img.At(r - 1, c) - v2) * kD2;
    const double dss = (nxt.At(r, c) + prv.At(r, c) - v2) * kD2;
    dxy = (img.At(r + 1, c + 1) - img.At(r + 1, c - 1) - img.At(r - 1, c + 1) +
           img.At(r - 1, c - 1)) *
          kDx;
    const double dxs =
        (nxt.At(r, c + 1) - nxt.At(r, c - 1) - prv.At(r, c + 1) + prv.At(r, c - 1)) * kDx;
    const double dys =
        (nxt.At(r + 1, c) - nxt.At(r - 1, c) - prv.At(r + 1, c) + prv.At(r - 1, c)) * kDx;
    Eigen::Matrix3d hessian;
    hessian << dxx, dxy, dxs, dxy, dyy, dys, dxs, dys, dss;
    x = -hessian.partialPivLu().solve(grad);
    if (!x.allFinite()) return false;
    if (x.cwiseAbs().maxCoeff() < 0.5) break;
    if (x.cwiseAbs().maxCoeff() > 1e6) return false;
    c += static_cast<int>(std::lround(x[0]));
    r += static_cast<int>(std::lround(x[1]));
    layer += static_cast<int>(std::lround(x[2]));
    if (layer < 1 || layer > layers || c < kBorder || c >= w - kBorder || r < kBorder ||
        r >= h - kBorder) {
      return false;
    }
  }
  if (step >= kMaxInterpSteps) return false;
  const Plane& img = dog[static_cast<size_t>(layer)];
  const double contr = img.At(r, c) * kScale + grad.dot(x) * 0.5;
  if (std::abs(contr) * layers < contrast_threshold) return false;
  const double tr = dxx + dyy, det = dxx * dyy - dxy * dxy;
  if (det <= 0 || tr * tr * kEdgeThreshold >= (kEdgeThreshold + 1) * (kEdgeThreshold + 1) * det) {
    return false;
  }
  kp->layer = layer;
  kp->r = r;
  kp->c = c;
  kp->xc = static_cast<float>(x[0]);
  kp->xr = static_cast<float>(x[1]);
  kp->xi = static_cast<float>(x[2]);
  kp->response = static_cast<float>(std::abs(contr));
  kp->scale = static_cast<float>(kSigma * std::pow(2.0, (layer + x[2]) / layers));
  return true;
}

// Lowe 2004 Sec. 5: 36-bin histogram of gradient directions weighted by magnitude and a
// Gaussian of 1.5 sigma, smoothed ([1 4 6 4 1] / 16, as OpenCV), one keypoint per peak within
// 80 % of the highest, interpolated by a parabola.
void AssignOrientations(const Plane& mag, const Plane& ori, const OctaveKeypoint& kp,
                        std::vector<OctaveKeypoint>* out) {
  const float sig = kOriSigmaFactor * kp.scale;
  const int radius = static_cast<int>(std::lround(kOriRadiusFactor * kp.scale));
  std::array<float, 64> wgt{};
  const int rr = std::min(radius, 31);
  for (int i = 0; i <= rr; ++i) {
    wgt[static_cast<size_t>(i)] = std::exp(-static_cast<float>(i * i) / (2 * sig * sig));
  }
  std::array<float, kOriBins + 4> raw{};
  float* hist = raw.data() + 2;
  for (int i = -rr; i <= rr; ++i) {
    const int y = kp.r + i;
    if (y <= 0 || y >= mag.h - 1) continue;
    const float wi = wgt[static_cast<size_t>(std::abs(i))];
    const float* mrow = mag.Row(y);
    const float* orow = ori.Row(y);
    const int x0 = std::max(1, kp.c - rr), x1 = std::min(mag.w - 2, kp.c + rr);
    for (int x = x0; x <= x1; ++x) {
      int bin = static_cast<int>(orow[x] * (kOriBins / 360.0f) + 0.5f);
      if (bin >= kOriBins) bin -= kOriBins;
      hist[bin] += wi * wgt[static_cast<size_t>(std::abs(x - kp.c))] * mrow[x];
    }
  }
  hist[-1] = hist[kOriBins - 1];
  hist[-2] = hist[kOriBins - 2];
  hist[kOriBins] = hist[0];
  hist[kOriBins + 1] = hist[1];
  std::array<float, kOriBins> smooth{};
  float max_value = 0;
  for (int i = 0; i < kOriBins; ++i) {
    smooth[static_cast<size_t>(i)] = (hist[i - 2] + hist[i + 2]) * (1.f / 16) +
                                     (hist[i - 1] + hist[i + 1]) * (4.f / 16) +
                                     hist[i] * (6.f / 16);
    max_value = std::max(max_value, smooth[static_cast<size_t>(i)]);
  }
  const float threshold = max_value * kOriPeakRatio;
  for (int j = 0; j < kOriBins; ++j) {
    const float l = smooth[static_cast<size_t>(j > 0 ? j - 1 : kOriBins - 1)];
    const float r = smooth[static_cast<size_t>(j < kOriBins - 1 ? j + 1 : 0)];
    const float v = smooth[static_cast<size_t>(j)];
    if (v > l && v > r && v >= threshold) {
      float bin = j + 0.5f * (l - r) / (l - 2 * v + r);
      bin = bin < 0 ? kOriBins + bin : bin >= kOriBins ? bin - kOriBins : bin;
      OctaveKeypoint k = kp;
      k.angle = 360.f - (360.f / kOriBins) * bin;
      if (std::abs(k.angle - 360.f) < FLT_EPSILON) k.angle = 0.f;
      out->push_back(k);
    }
  }
}

// Lowe 2004 Sec. 6.1: trilinear interpolation of the window's samples into 4x4x8 bins, then
// normalize, clamp at 0.2, renormalize and scale to integers in [0, 255] (OpenCV's 512 and
// saturation).
void Describe(const Plane& mag, const Plane& ori, const OctaveKeypoint& kp,
              DescriptorSamples* samples, float* dst) {
  constexpr int d = kDescWidth, n = kDescBins;
  const float x = static_cast<float>(kp.c) + kp.xc, y = static_cast<float>(kp.r) + kp.xr;
  DescriptorWindow win;
  win.cx = static_cast<int>(std::lround(x));
  win.cy = static_cast<int>(std::lround(y));
  win.dx0 = x - static_cast<float>(win.cx);
  win.dy0 = y - static_cast<float>(win.cy);
  float ori_deg = 360.f - kp.angle;
  if (std::abs(ori_deg - 360.f) < FLT_EPSILON) ori_deg = 0.f;
  win.ori_deg = ori_deg;
  const float hist_width = kDescBinWidth * kp.scale;
  const float angle = ori_deg * static_cast<float>(CV_PI / 180);
  win.cos_t = std::cos(angle) / hist_width;
  win.sin_t = std::sin(angle) / hist_width;
  win.radius = static_cast<int>(std::lround(hist_width * 1.4142135623730951f * (d + 1) * 0.5f));
  win.radius =
      std::min(win.radius, static_cast<int>(std::sqrt(static_cast<double>(mag.w) * mag.w +
                                                      static_cast<double>(mag.h) * mag.h)));
  CollectDescriptorSamples(mag, ori, win, samples);

  // Four interleaved histograms: consecutive samples mostly hit the same bins, and one
  // histogram would chain every update through store-to-load forwarding.
  constexpr size_t kHist = (d + 2) * (d + 2) * (n + 2);
  static_assert(kHist == 360, "6 x 6 x 10 cells, as CollectDescriptorSamples indexes them");
  std::array<float, 4 * kHist> hists{};
  for (size_t k = 0; k < samples->n; ++k) {
    const float m = samples->mag[k], fr = samples->rfrac[k], fc = samples->cfrac[k],
                fo = samples->ofrac[k];
    float* h = hists.data() + (k & 3) * kHist + samples->bin[k];
    const float v_r1 = m * fr, v_r0 = m - v_r1;
    const float v_rc11 = v_r1 * fc, v_rc10 = v_r1 - v_rc11;
    const float v_rc01 = v_r0 * fc, v_rc00 = v_r0 - v_rc01;
    const float v_rco111 = v_rc11 * fo, v_rco110 = v_rc11 - v_rco111;
    const float v_rco101 = v_rc10 * fo, v_rco100 = v_rc10 - v_rco101;
    const float v_rco011 = v_rc01 * fo, v_rco010 = v_rc01 - v_rco011;
    const float v_rco001 = v_rc00 * fo, v_rco000 = v_rc00 - v_rco001;
    h[0] += v_rco000;
    h[1] += v_rco001;
    h[n + 2] += v_rco010;
    h[n + 3] += v_rco011;
    h[(d + 2) * (n + 2)] += v_rco100;
    h[(d + 2) * (n + 2) + 1] += v_rco101;
    h[(d + 3) * (n + 2)] += v_rco110;
    h[(d + 3) * (n + 2) + 1] += v_rco111;
  }
  std::array<float, kHist> hist;
  for (size_t i = 0; i < kHist; ++i) {
    hist[i] = (hists[i] + hists[kHist + i]) + (hists[2 * kHist + i] + hists[3 * kHist + i]);
  }
  float raw[d * d * n];
  for (int i = 0; i < d; ++i) {
    for (int j = 0; j < d; ++j) {
      const size_t idx = static_cast<size_t>(((i + 1) * (d + 2) + (j + 1)) * (n + 2));
      hist[idx] += hist[idx + n];
      hist[idx + 1] += hist[idx + n + 1];
      for (int k = 0; k < n; ++k) raw[(i * d + j) * n + k] = hist[idx + static_cast<size_t>(k)];
    }
  }
  float nrm2 = 0;
  for (const float v : raw) nrm2 += v * v;
  const float thr = std::sqrt(nrm2) * kDescClamp;
  nrm2 = 0;
  for (float& v : raw) {
    v = std::min(v, thr);
    nrm2 += v * v;
  }
  const float s = kDescScale / std::max(std::sqrt(nrm2), FLT_EPSILON);
  for (int k = 0; k < d * d * n; ++k) {
    dst[k] = static_cast<float>(cv::saturate_cast<uint8_t>(raw[k] * s));
  }
}

}  // namespace

namespace {
// The pyramid's planes, kept per thread between calls (fresh pages cost more than a blur).
Workspace& ThreadWorkspace() {
  thread_local Workspace ws;
  return ws;
}
}  // namespace

void ReleaseWorkspace() { ThreadWorkspace() = Workspace{}; }

Features ExtractSiftOwn(const cv::Mat& input, const SiftOptions& options) {
  CV_Assert(input.type() == CV_8UC1);
  const int layers = options.octave_layers;
  const int first = options.first_octave;
  // Resize first (as the OpenCV path does); keypoints are mapped back at the end.
  cv::Mat gray = input;
  if (options.resize_factor < 1.0) {
    cv::resize(input, gray, cv::Size(), options.resize_factor, options.resize_factor,
               cv::INTER_AREA);
  }
  // First octave (Lowe 2004 Sec. 3.3): -1 doubles the image (assumed blur 2 x 0.5), k >= 1
  // averages 2^k x 2^k blocks. The base is then blurred to sigma.
  Workspace& ws = ThreadWorkspace();
  float init_sigma = kInitSigma;
  if (first < 0) {
    ToPlane(gray, 2, &ws.input);
    init_sigma = 2 * kInitSigma;
  } else if (first == 0) {
    ToPlane(gray, 1, &ws.input);
  } else {
    cv::Mat small;
    const double f = std::ldexp(1.0, -first);
    cv::resize(gray, small, cv::Size(), f, f, cv::INTER_AREA);
    ToPlane(small, 1, &ws.input);
  }
  const double sig_diff = std::sqrt(std::max(kSigma * kSigma - init_sigma * init_sigma, 0.01));
  Blur(ws.input, GaussianHalfKernel(sig_diff), &ws.base);
  const Plane& base = ws.base;
  // Incremental blurs: layer i = layer i-1 convolved with sqrt(s_i^2 - s_{i-1}^2), s_i =
  // sigma k^i, k = 2^(1/layers) (the smallest kernels that reach each scale).
  std::vector<std::vector<float>> kernels(static_cast<size_t>(layers + 3));
  const double k = std::pow(2.0, 1.0 / layers);
  for (int i = 1; i < layers + 3; ++i) {
    const double prev = std::pow(k, i - 1) * kSigma, total = prev * k;
    kernels[static_cast<size_t>(i)] = GaussianHalfKernel(std::sqrt(total * total - prev * prev));
  }
  // OpenCV's octave count for its doubled base, plus one; octaves too small for the border
  // stop the loop below.
  const int octaves =
      static_cast<int>(std::lround(std::log2(static_cast<double>(std::min(base.w, base.h))) - 2)) +
      1;
  // Contrast prefilter of the 3x3x3 test: half the final threshold (OpenCV's value).
  const float prefilter =
      static_cast<float>(std::floor(0.5 * options.contrast_threshold / layers * 255));

  std::vector<Plane>& gauss = ws.gauss;
  std::vector<Plane>& dog = ws.dog;
  gauss.resize(static_cast<size_t>(layers + 3));
  dog.resize(static_cast<size_t>(layers + 2));
  // Gradient maps of the layers that hold keypoints, per octave and layer.
  auto& mags = ws.mags;
  auto& oris = ws.oris;
  if (mags.size() < static_cast<size_t>(octaves)) {
    mags.resize(static_cast<size_t>(octaves));
    oris.resize(static_cast<size_t>(octaves));
  }
  std::vector<std::vector<char>> have_grad(static_cast<size_t>(octaves),
                                           std::vector<char>(static_cast<size_t>(layers + 1), 0));
  std::vector<OctaveKeypoint> keypoints;
  std::vector<int>& candidates = ws.candidates;
  for (int o = 0; o < octaves; ++o) {
    // Layer 0 of octave o > 0 is layer `layers` of octave o - 1 (twice its sigma) halved; it
    // goes through gauss[layers + 2], which is rewritten below.
    const Plane* g0 = &base;
    if (o > 0) {
      Decimate(gauss[static_cast<size_t>(layers)], &gauss[static_cast<size_t>(layers + 2)]);
      std::swap(gauss[0], gauss[static_cast<size_t>(layers + 2)]);
      g0 = &gauss[0];
    }
    if (g0->w <= 2 * kBorder + 2 || g0->h <= 2 * kBorder + 2) break;
    for (int i = 1; i < layers + 3; ++i) {
      Blur(i == 1 ? *g0 : gauss[static_cast<size_t>(i - 1)], kernels[static_cast<size_t>(i)],
           &gauss[static_cast<size_t>(i)], &dog[static_cast<size_t>(i - 1)]);
    }
    auto& mag = mags[static_cast<size_t>(o)];
    auto& ori = oris[static_cast<size_t>(o)];
    mag.resize(static_cast<size_t>(layers + 1));
    ori.resize(static_cast<size_t>(layers + 1));
    const int w = g0->w;
    for (int i = 1; i <= layers; ++i) {
      candidates.clear();
      FindExtrema(dog[static_cast<size_t>(i - 1)], dog[static_cast<size_t>(i)],
                  dog[static_cast<size_t>(i + 1)], prefilter, kBorder, &candidates);
      for (const int p : candidates) {
        OctaveKeypoint kp;
        kp.octave = o;
        kp.layer = i;
        kp.r = p / w;
        kp.c = p % w;
        if (!Refine(dog, layers, options.contrast_threshold, &kp)) continue;
        const auto l = static_cast<size_t>(kp.layer);
        if (!have_grad[static_cast<size_t>(o)][l]) {
          GradientPolar(gauss[l], &mag[l], &ori[l]);
          have_grad[static_cast<size_t>(o)][l] = 1;
        }
        AssignOrientations(mag[l], ori[l], kp, &keypoints);
      }
    }
  }

  // Duplicates (two samples refined to the same point), as OpenCV's removeDuplicatedSorted.
  auto key = [](const OctaveKeypoint& a) {
    return std::make_tuple(a.octave, a.layer, a.r, a.c, a.xc, a.xr, a.xi, a.angle);
  };
  std::sort(keypoints.begin(), keypoints.end(),
            [&](const OctaveKeypoint& a, const OctaveKeypoint& b) { return key(a) < key(b); });
  keypoints.erase(std::unique(keypoints.begin(), keypoints.end(),
                              [&](const OctaveKeypoint& a, const OctaveKeypoint& b) {
                                return key(a) == key(b);
                              }),
                  keypoints.end());
  // Keep the strongest by response before describing them.
  if (options.max_features > 0 && keypoints.size() > static_cast<size_t>(options.max_features)) {
    std::stable_sort(
        keypoints.begin(), keypoints.end(),
        [](const OctaveKeypoint& a, const OctaveKeypoint& b) { return a.response > b.response; });
    keypoints.resize(static_cast<size_t>(options.max_features));
  }

  Features out;
  out.descriptors.create(static_cast<int>(keypoints.size()), kDescWidth * kDescWidth * kDescBins,
                         CV_32F);
  out.keypoints.reserve(keypoints.size());
  DescriptorSamples& samples = ws.samples;
  // Original pixels: base pixel p of octave o is (p 2^o + 0.5) 2^first - 0.5 (centres aligned),
  // then the resize factor's exact per-axis ratio.
  const double sx = static_cast<double>(input.cols) / gray.cols;
  const double sy = static_cast<double>(input.rows) / gray.rows;
  for (size_t i = 0; i < keypoints.size(); ++i) {
    const OctaveKeypoint& kp = keypoints[i];
    const auto l = static_cast<size_t>(kp.layer);
    const auto o = static_cast<size_t>(kp.octave);
    Describe(mags[o][l], oris[o][l], kp, &samples, out.descriptors.ptr<float>(static_cast<int>(i)));
    const double to_base = std::ldexp(1.0, kp.octave);
    const double to_gray = std::ldexp(1.0, first);
    const double xb = (kp.c + kp.xc) * to_base, yb = (kp.r + kp.xr) * to_base;
    const double xg = (xb + 0.5) * to_gray - 0.5, yg = (yb + 0.5) * to_gray - 0.5;
    cv::KeyPoint ck;
    ck.pt = cv::Point2f(static_cast<float>((xg + 0.5) * sx - 0.5),
                        static_cast<float>((yg + 0.5) * sy - 0.5));
    ck.size = static_cast<float>(kp.scale * 2 * to_base * to_gray * 0.5 * (sx + sy));
    ck.angle = kp.angle;
    ck.response = kp.response;
    ck.octave = ((kp.octave + first) & 255) | (kp.layer << 8) |
                (static_cast<int>(std::lround((kp.xi + 0.5) * 255)) << 16);
    out.keypoints.push_back(ck);
  }
  return out;
}

}  // namespace mm::sift
