#include "synth/corridor.h"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <limits>
#include <numeric>
#include <opencv2/imgproc.hpp>
#include <stdexcept>

namespace mm {
namespace {

constexpr int kPadTexels = 8;  // Replicated border around each rectangle: mip levels 0-3 clean.
const Eigen::Vector3d kUp = Eigen::Vector3d::UnitZ();

// A wall stretch that doors, posters and boxes are put on: from `start` along `right` (unit,
// horizontal) for `length` metres, facing `normal`.
struct WallRun {
  Eigen::Vector3d start;
  Eigen::Vector3d right;
  Eigen::Vector3d normal;
  double length = 0.0;
  std::vector<std::pair<double, double>> taken;  // Occupied [from, to] along the run.

  bool Free(double from, double to, double margin) const {
    if (from < 0.3 || to > length - 0.3) return false;
    return std::none_of(taken.begin(), taken.end(), [&](const auto& t) {
      return from < t.second + margin && to > t.first - margin;
    });
  }
};

class SceneBuilder {
 public:
  explicit SceneBuilder(CorridorScene* scene) : scene_(*scene) {}

  // A vertical rectangle seen from the side `normal` points to: bottom edge centred on
  // `bottom_centre`; texture upright and left-to-right as seen from there.
  void Vertical(const Eigen::Vector3d& bottom_centre, const Eigen::Vector3d& normal, double width,
                double height, SurfaceKind kind, double panel) {
    const Eigen::Vector3d right = (-normal).cross(kUp).normalized();
    const Eigen::Vector3d origin = bottom_centre - right * (width / 2) + kUp * height;
    Split(origin, right * width, -kUp * height, normal, kind, panel);
  }

  // A horizontal rectangle [x0, x1] x [y0, y1] at height z, seen from above (floor, box tops;
  // texture north-up) or from below (ceiling).
  void Horizontal(double x0, double x1, double y0, double y1, double z, bool from_above,
                  SurfaceKind kind, double panel) {
    if (from_above) {
      Split({x0, y1, z}, {x1 - x0, 0, 0}, {0, y0 - y1, 0}, kUp, kind, panel);
    } else {
      Split({x0, y0, z}, {x1 - x0, 0, 0}, {0, y1 - y0, 0}, -kUp, kind, panel);
    }
  }

 private:
  // Splits the rectangle into equal panels of at most `panel` metres (0: no split).
  void Split(const Eigen::Vector3d& origin, const Eigen::Vector3d& edge_u,
             const Eigen::Vector3d& edge_v, const Eigen::Vector3d& normal, SurfaceKind kind,
             double panel) {
    const int nu =
        panel > 0 ? std::max(1, static_cast<int>(std::ceil(edge_u.norm() / panel - 1e-9))) : 1;
    const int nv =
        panel > 0 ? std::max(1, static_cast<int>(std::ceil(edge_v.norm() / panel - 1e-9))) : 1;
    for (int j = 0; j < nv; ++j) {
      for (int i = 0; i < nu; ++i) {
        SceneQuad q;
        q.origin = origin + edge_u * (static_cast<double>(i) / nu) +
                   edge_v * (static_cast<double>(j) / nv);
        q.edge_u = edge_u / nu;
        q.edge_v = edge_v / nv;
        q.normal = normal;
        q.kind = kind;
        scene_.quads.push_back(q);
      }
    }
  }

  CorridorScene& scene_;
};

// ---- Procedural textures -------------------------------------------------------------------

// Value noise in [-1, 1]: uniform random values every `cell` texels, bicubic in between.
cv::Mat ValueNoise(cv::Size size, double cell, cv::RNG& rng) {
  cell = std::max(cell, 1.5);
  const int gw = static_cast<int>(std::ceil(size.width / cell)) + 3;
  const int gh = static_cast<int>(std::ceil(size.height / cell)) + 3;
  cv::Mat grid(gh, gw, CV_32FC1);
  rng.fill(grid, cv::RNG::UNIFORM, -1.0, 1.0);
  cv::Mat big;
  cv::resize(
      grid, big,
      cv::Size(static_cast<int>(std::lround(gw * cell)), static_cast<int>(std::lround(gh * cell))),
      0, 0, cv::INTER_CUBIC);
  const int ox = static_cast<int>(cell), oy = static_cast<int>(cell);  // Skip the edge cells.
  return big(cv::Rect(ox, oy, size.width, size.height)).clone();
}

cv::Scalar Jitter(const cv::Scalar& bgr, double amount, cv::RNG& rng) {
  cv::Scalar out;
  for (int c = 0; c < 3; ++c) {
    out[c] = std::clamp(bgr[c] + rng.uniform(-amount, amount), 0.0, 255.0);
  }
  return out;
}

cv::Scalar RandomColour(cv::RNG& rng, double lo = 0, double hi = 255) {
  return {rng.uniform(lo, hi), rng.uniform(lo, hi), rng.uniform(lo, hi)};
}

// What a material puts on its surface; densities per square metre, sizes in metres.
struct Material {
  cv::Scalar base;              // BGR.
  double noise_contrast = 0.5;  // Relative luminance swing of the multi-scale noise.
  double colour_noise = 12.0;   // Per-channel noise, grey levels.
  double shapes_per_m2 = 10.0;  // Rectangles and ellipses.
  double shape_min_m = 0.02, shape_max_m = 0.25;
  double shape_contrast = 70.0;  // How far shape colours stray from the base.
  double text_per_m2 = 2.0;
  double text_min_m = 0.015, text_max_m = 0.08;
  double dots_per_m2 = 0.0;  // Speckles / acoustic holes.
  double dot_min_m = 0.002, dot_max_m = 0.006;
  double grid_m = 0.0;  // Tile grid pitch (0: none).
  double grid_line_m = 0.004;
  double strokes_per_m2 = 0.0;  // Scribbles (polylines).
};

Material MaterialFor(SurfaceKind kind, cv::RNG& rng) {
  Material m;
  switch (kind) {
    case SurfaceKind::kFloor:
      m.base = Jitter({120, 140, 160}, 30, rng);
      m.noise_contrast = 0.55;
      m.shapes_per_m2 = 8;
      m.shape_contrast = 50;
      m.text_per_m2 = 1.0;
      m.dots_per_m2 = 250;
      m.dot_min_m = 0.003;
      m.dot_max_m = 0.01;
      m.grid_m = 0.5;
      m.grid_line_m = 0.006;
      break;
    case SurfaceKind::kCeiling:
      m.base = Jitter({200, 205, 205}, 15, rng);
      m.noise_contrast = 0.35;
      m.shapes_per_m2 = 5;
      m.shape_contrast = 60;
      m.text_per_m2 = 0.8;
      m.dots_per_m2 = 300;
      m.dot_min_m = 0.003;
      m.dot_max_m = 0.008;
      m.grid_m = 0.6;
      m.grid_line_m = 0.01;
      break;
    case SurfaceKind::kWall:
      m.base = Jitter({170, 185, 190}, 45, rng);
      m.noise_contrast = 0.45;
      m.shapes_per_m2 = 12;
      m.text_per_m2 = 3;
      m.strokes_per_m2 = 2;
      break;
    case SurfaceKind::kDoor:
      m.base = Jitter({40, 80, 130}, 25, rng);
      m.noise_contrast = 0.6;
      m.shapes_per_m2 = 6;
      m.shape_contrast = 40;
      m.text_per_m2 = 1;
      break;
    case SurfaceKind::kPoster:
      m.base = Jitter({230, 235, 235}, 20, rng);
      m.noise_contrast = 0.15;
      m.shapes_per_m2 = 30;
      m.shape_min_m = 0.03;
      m.shape_max_m = 0.3;
      m.shape_contrast = 200;
      m.text_per_m2 = 25;
      m.text_min_m = 0.01;
      m.text_max_m = 0.06;
      break;
    case SurfaceKind::kBox:
      m.base = Jitter({90, 130, 170}, 40, rng);
      m.noise_contrast = 0.5;
      m.shapes_per_m2 = 15;
      m.text_per_m2 = 6;
      m.strokes_per_m2 = 3;
      break;
  }
  return m;
}

std::string RandomText(cv::RNG& rng) {
  static const char kChars[] = "ABCDEFGHJKLMNPQRSTUVWXYZ0123456789-abcdefghkmnpqrstuvwxyz";
  const int n = rng.uniform(3, 11);
  std::string s;
  for (int i = 0; i < n; ++i) s += kChars[rng.uniform(0, static_cast<int>(sizeof(kChars)) - 1)];
  return s;
}

// Paints the quad's material into a `size` texel image (texels_per_m along both edges).
cv::Mat PaintTexture(const SceneQuad& quad, cv::Size size, double texels_per_m, cv::RNG& rng) {
  const Material m = MaterialFor(quad.kind, rng);
  const double d = texels_per_m;
  const double area = quad.edge_u.norm() * quad.edge_v.norm();
  auto count = [&](double per_m2) {
    const double n = per_m2 * area;
    return static_cast<int>(n) + (rng.uniform(0.0, 1.0) < n - std::floor(n) ? 1 : 0);
  };

  // Multi-scale luminance noise (1 cm to 40 cm features) and a little colour noise.
  cv::Mat lum(size, CV_32FC1, cv::Scalar(0));
  const std::array<std::pair<double, double>, 4> octaves{
      {{0.01, 0.35}, {0.03, 0.3}, {0.1, 0.25}, {0.4, 0.2}}};
  if (quad.kind == SurfaceKind::kDoor) {
    // Wood grain: noise stretched along the door's height.
    cv::Mat grain = ValueNoise(cv::Size(size.height, size.width), 0.004 * d, rng);
    cv::Mat stretched;
    cv::resize(grain(cv::Rect(0, 0, std::max(2, size.height / 40), size.width)), stretched,
               cv::Size(size.height, size.width), 0, 0, cv::INTER_LINEAR);
    cv::transpose(stretched, grain);
    lum += 0.5 * grain;
  }
  for (const auto& [cell_m, amplitude] : octaves) {
    lum += amplitude * ValueNoise(size, cell_m * d, rng);
  }
  std::vector<cv::Mat> channels(3);
  for (int c = 0; c < 3; ++c) {
    cv::Mat colour_noise = ValueNoise(size, 0.05 * d, rng);
    channels[static_cast<size_t>(c)] =
        m.base[c] * (1.0 + m.noise_contrast * lum) + m.colour_noise * colour_noise;
  }
  cv::Mat image_f, image;
  cv::merge(channels, image_f);
  image_f.convertTo(image, CV_8UC3);  // Saturating.

  const auto to_px = [d](double metres) { return metres * d; };
  const auto random_point = [&]() {
    return cv::Point(rng.uniform(0, size.width), rng.uniform(0, size.height));
  };
  if (m.grid_m > 0) {
    const cv::Scalar line = m.base * 0.45;
    const int thickness = std::max(1, static_cast<int>(std::lround(to_px(m.grid_line_m))));
    const double offset_u = rng.uniform(0.0, m.grid_m), offset_v = rng.uniform(0.0, m.grid_m);
    for (double x = offset_u; to_px(x) < size.width; x += m.grid_m) {
      const int px = static_cast<int>(to_px(x));
      cv::line(image, {px, 0}, {px, size.height}, line, thickness, cv::LINE_AA);
    }
    for (double y = offset_v; to_px(y) < size.height; y += m.grid_m) {
      const int py = static_cast<int>(to_px(y));
      cv::line(image, {0, py}, {size.width, py}, line, thickness, cv::LINE_AA);
    }
  }
  for (int i = count(m.dots_per_m2); i > 0; --i) {
    const int r = std::max(1, static_cast<int>(to_px(rng.uniform(m.dot_min_m, m.dot_max_m))));
    const cv::Scalar c = rng.uniform(0, 2) ? m.base * 0.4 : Jitter(m.base * 1.3, 30, rng);
    cv::circle(image, random_point(), r, c, cv::FILLED, cv::LINE_AA);
  }
  for (int i = count(m.shapes_per_m2); i > 0; --i) {
    const cv::Scalar c = Jitter(m.base, m.shape_contrast, rng);
    const cv::Point p = random_point();
    const int a = std::max(2, static_cast<int>(to_px(rng.uniform(m.shape_min_m, m.shape_max_m))));
    const int b = std::max(2, static_cast<int>(to_px(rng.uniform(m.shape_min_m, m.shape_max_m))));
    const int thickness = rng.uniform(0, 3) == 0 ? std::max(1, a / 8) : cv::FILLED;
    if (rng.uniform(0, 2) == 0) {
      cv::rectangle(image, p, p + cv::Point(a, b), c, thickness, cv::LINE_AA);
    } else {
      cv::ellipse(image, p, {a / 2, b / 2}, rng.uniform(0.0, 180.0), 0, 360, c, thickness,
                  cv::LINE_AA);
    }
  }
  for (int i = count(m.strokes_per_m2); i > 0; --i) {
    std::vector<cv::Point> line{random_point()};
    for (int k = 0; k < 6; ++k) {
      line.push_back(line.back() + cv::Point(static_cast<int>(to_px(rng.uniform(-0.08, 0.08))),
                                             static_cast<int>(to_px(rng.uniform(-0.08, 0.08)))));
    }
    cv::polylines(image, line, false, m.base * 0.3, std::max(1, static_cast<int>(to_px(0.004))),
                  cv::LINE_AA);
  }
  static const std::array<int, 4> kFonts{cv::FONT_HERSHEY_SIMPLEX, cv::FONT_HERSHEY_DUPLEX,
                                         cv::FONT_HERSHEY_COMPLEX, cv::FONT_HERSHEY_TRIPLEX};
  for (int i = count(m.text_per_m2); i > 0; --i) {
    const int font = kFonts[static_cast<size_t>(rng.uniform(0, 4))];
    const double height_px = to_px(rng.uniform(m.text_min_m, m.text_max_m));
    const double scale = height_px / 22.0;  // Hershey glyphs are ~22 units tall at scale 1.
    const int thickness = std::max(1, static_cast<int>(std::lround(scale * rng.uniform(1.0, 3.0))));
    const cv::Scalar c = rng.uniform(0, 2) ? m.base * 0.25 : RandomColour(rng, 0, 160);
    cv::putText(image, RandomText(rng), random_point(), font, scale, c, thickness, cv::LINE_AA);
  }
  if (quad.kind == SurfaceKind::kDoor) {  // Two panels and a handle.
    const cv::Scalar dark = m.base * 0.5;
    const int t = std::max(1, static_cast<int>(to_px(0.015)));
    cv::rectangle(
        image, cv::Point(static_cast<int>(0.12 * size.width), static_cast<int>(0.08 * size.height)),
        cv::Point(static_cast<int>(0.88 * size.width), static_cast<int>(0.45 * size.height)), dark,
        t, cv::LINE_AA);
    cv::rectangle(
        image, cv::Point(static_cast<int>(0.12 * size.width), static_cast<int>(0.55 * size.height)),
        cv::Point(static_cast<int>(0.88 * size.width), static_cast<int>(0.92 * size.height)), dark,
        t, cv::LINE_AA);
    const cv::Point handle(static_cast<int>(0.88 * size.width),
                           static_cast<int>(size.height - to_px(1.0)));
    cv::rectangle(image,
                  handle - cv::Point(static_cast<int>(to_px(0.02)), static_cast<int>(to_px(0.07))),
                  handle + cv::Point(static_cast<int>(to_px(0.02)), static_cast<int>(to_px(0.07))),
                  cv::Scalar(40, 40, 40), cv::FILLED, cv::LINE_AA);
  }
  if (quad.kind == SurfaceKind::kBox) {  // A tape stripe across the face.
    const int y = rng.uniform(0, std::max(1, size.height));
    cv::rectangle(image, {0, y}, {size.width, y + static_cast<int>(to_px(0.05))},
                  Jitter({60, 170, 200}, 30, rng), cv::FILLED);
  }
  return image;
}

// Draws a marker at the texture's centre: a magenta disc in a black ring.
void PaintMarker(cv::Mat* image, double radius_px) {
  // Drawing coordinates are texel centres; the rectangle's middle is at (w/2, h/2) in texel
  // edges, so (w/2 - 0.5, h/2 - 0.5) here.
  const cv::Point2d c(image->cols / 2.0 - 0.5, image->rows / 2.0 - 0.5);
  // Shift by 4 fractional bits: sub-texel centres (the rectangle's exact middle).
  const int shift = 4;
  const cv::Point centre(static_cast<int>(std::lround(c.x * 16)),
                         static_cast<int>(std::lround(c.y * 16)));
  cv::circle(*image, centre, static_cast<int>(std::lround(1.6 * radius_px * 16)),
             cv::Scalar(0, 0, 0), cv::FILLED, cv::LINE_AA, shift);
  cv::circle(*image, centre, static_cast<int>(std::lround(radius_px * 16)),
             cv::Scalar(kMarkerBgr[0], kMarkerBgr[1], kMarkerBgr[2]), cv::FILLED, cv::LINE_AA,
             shift);
}

// Shelf packing of the quads' rectangles (tallest first) at `d` texels per metre; false when
// they do not fit the atlas.
bool Pack(std::vector<SceneQuad>* quads, double d, int atlas) {
  std::vector<size_t> order(quads->size());
  std::iota(order.begin(), order.end(), 0);
  auto size_of = [&](const SceneQuad& q) {
    return cv::Size(std::max(4, static_cast<int>(std::lround(q.edge_u.norm() * d))),
                    std::max(4, static_cast<int>(std::lround(q.edge_v.norm() * d))));
  };
  std::stable_sort(order.begin(), order.end(), [&](size_t a, size_t b) {
    return size_of((*quads)[a]).height > size_of((*quads)[b]).height;
  });
  int x = 0, y = 0, row = 0;
  for (size_t i : order) {
    const cv::Size s = size_of((*quads)[i]);
    const int w = s.width + 2 * kPadTexels, h = s.height + 2 * kPadTexels;
    if (w > atlas) return false;
    if (x + w > atlas) {
      x = 0;
      y += row;
      row = 0;
    }
    if (y + h > atlas) return false;
    (*quads)[i].atlas_rect = cv::Rect(x + kPadTexels, y + kPadTexels, s.width, s.height);
    x += w;
    row = std::max(row, h);
  }
  return true;
}

}  // namespace

std::string CorridorOptions::Check() const {
  if (!(width_m >= 1.0 && width_m <= 10.0)) return "width_m: must be in [1, 10]";
  if (!(height_m >= 2.0 && height_m <= 10.0)) return "height_m: must be in [2, 10]";
  if (!(leg1_length_m >= width_m + 4.0)) return "leg1_length_m: must be >= width_m + 4";
  if (!(leg2_length_m >= width_m + 2.0)) return "leg2_length_m: must be >= width_m + 2";
  if (!(panel_m >= 0.5)) return "panel_m: must be >= 0.5";
  if (doors < 0 || posters < 0 || boxes < 0) return "doors/posters/boxes: must be >= 0";
  if (atlas_size < 256 || atlas_size > 16384) return "atlas_size: must be in [256, 16384]";
  if (!(marker_radius_m > 0.0 && marker_radius_m < 0.3)) {
    return "marker_radius_m: must be in (0, 0.3)";
  }
  return {};
}

CorridorLayout LayoutOf(const CorridorOptions& o) {
  CorridorLayout l;
  l.half_width = o.width_m / 2;
  l.start_y = -2.0;
  l.outer_y = l.start_y + o.leg1_length_m;
  l.end_x = -l.half_width + o.leg2_length_m;
  l.height = o.height_m;
  return l;
}

CorridorScene BuildCorridor(const CorridorOptions& options) {
  if (const std::string problem = options.Check(); !problem.empty()) {
    throw std::invalid_argument("CorridorOptions." + problem);
  }
  const auto start = std::chrono::steady_clock::now();
  CorridorScene scene;
  scene.options = options;
  const CorridorLayout l = LayoutOf(options);
  const double h = l.half_width, w = options.width_m, H = l.height;
  const double inner_y = l.outer_y - w;  // Leg 2's south wall; leg 1's east wall ends here.
  const double panel = options.panel_m;
  SceneBuilder b(&scene);

  // Floor and ceiling: leg 1 up to the corner, then the corner square and leg 2 as one strip.
  b.Horizontal(-h, h, l.start_y, inner_y, 0.0, true, SurfaceKind::kFloor, panel);
  b.Horizontal(-h, l.end_x, inner_y, l.outer_y, 0.0, true, SurfaceKind::kFloor, panel);
  b.Horizontal(-h, h, l.start_y, inner_y, H, false, SurfaceKind::kCeiling, panel);
  b.Horizontal(-h, l.end_x, inner_y, l.outer_y, H, false, SurfaceKind::kCeiling, panel);
  // Walls, each seen from inside the corridor.
  std::vector<WallRun> runs;
  auto wall = [&](const Eigen::Vector3d& a, const Eigen::Vector3d& c, const Eigen::Vector3d& n,
                  bool long_wall) {
    const Eigen::Vector3d mid = (a + c) / 2;
    const double length = (c - a).norm();
    b.Vertical(mid, n, length, H, SurfaceKind::kWall, panel);
    if (long_wall) {
      const Eigen::Vector3d right = (-n).cross(kUp).normalized();
      runs.push_back({mid - right * (length / 2), right, n, length, {}});
    }
  };
  wall({-h, l.start_y, 0}, {-h, l.outer_y, 0}, Eigen::Vector3d::UnitX(), true);            // West.
  wall({h, l.start_y, 0}, {h, inner_y, 0}, -Eigen::Vector3d::UnitX(), true);               // East.
  wall({-h, l.start_y, 0}, {h, l.start_y, 0}, Eigen::Vector3d::UnitY(), false);            // Start.
  wall({-h, l.outer_y, 0}, {l.end_x, l.outer_y, 0}, -Eigen::Vector3d::UnitY(), true);      // North.
  wall({h, inner_y, 0}, {l.end_x, inner_y, 0}, Eigen::Vector3d::UnitY(), true);            // South.
  wall({l.end_x, inner_y, 0}, {l.end_x, l.outer_y, 0}, -Eigen::Vector3d::UnitX(), false);  // End.
  const size_t structural = scene.quads.size();

  // Doors, posters and boxes on the long walls, never overlapping one another.
  cv::RNG rng(options.seed * 0x9E3779B97F4A7C15ULL + 1);
  double total_length = 0;
  for (const WallRun& r : runs) total_length += r.length;
  auto place = [&](double width, double margin) -> std::pair<WallRun*, double> {
    for (int attempt = 0; attempt < 200; ++attempt) {
      double pick = rng.uniform(0.0, total_length);
      size_t k = 0;
      while (k + 1 < runs.size() && pick > runs[k].length) pick -= runs[k++].length;
      WallRun& run = runs[k];
      const double from = rng.uniform(0.0, std::max(0.0, run.length - width));
      if (run.Free(from, from + width, margin)) {
        run.taken.emplace_back(from, from + width);
        return {&run, from};
      }
    }
    return {nullptr, 0.0};
  };
  for (int i = 0; i < options.doors; ++i) {
    const double dw = 0.9, dh = std::min(2.05, H - 0.2);
    auto [run, from] = place(dw, 0.3);
    if (run == nullptr) continue;
    b.Vertical(run->start + run->right * (from + dw / 2) + run->normal * 0.02, run->normal, dw, dh,
               SurfaceKind::kDoor, 0.0);
  }
  for (int i = 0; i < options.boxes; ++i) {
    const double bw = rng.uniform(0.4, 1.0), depth = rng.uniform(0.3, 0.5);
    const double bh = rng.uniform(0.4, 1.1);
    auto [run, from] = place(bw, 0.2);
    if (run == nullptr) continue;
    // Axis-aligned: the wall runs along x or y, the box stands 3 cm off it.
    const Eigen::Vector3d a = run->start + run->right * from + run->normal * 0.03;
    const Eigen::Vector3d c = a + run->right * bw + run->normal * depth;
    const double x0 = std::min(a.x(), c.x()), x1 = std::max(a.x(), c.x());
    const double y0 = std::min(a.y(), c.y()), y1 = std::max(a.y(), c.y());
    b.Horizontal(x0, x1, y0, y1, bh, true, SurfaceKind::kBox, 0.0);
    b.Vertical({x1, (y0 + y1) / 2, 0}, Eigen::Vector3d::UnitX(), y1 - y0, bh, SurfaceKind::kBox,
               0.0);
    b.Vertical({x0, (y0 + y1) / 2, 0}, -Eigen::Vector3d::UnitX(), y1 - y0, bh, SurfaceKind::kBox,
               0.0);
    b.Vertical({(x0 + x1) / 2, y1, 0}, Eigen::Vector3d::UnitY(), x1 - x0, bh, SurfaceKind::kBox,
               0.0);
    b.Vertical({(x0 + x1) / 2, y0, 0}, -Eigen::Vector3d::UnitY(), x1 - x0, bh, SurfaceKind::kBox,
               0.0);
  }
  for (int i = 0; i < options.posters; ++i) {
    const double pw = rng.uniform(0.5, 1.0), ph = rng.uniform(0.4, 0.9);
    const double centre_z = std::min(rng.uniform(1.35, 1.65), H - ph / 2 - 0.1);
    auto [run, from] = place(pw, 0.15);
    if (run == nullptr) continue;
    b.Vertical(
        run->start + run->right * (from + pw / 2) + run->normal * 0.01 + kUp * (centre_z - ph / 2),
        run->normal, pw, ph, SurfaceKind::kPoster, 0.0);
  }

  // Atlas: the largest texel density at which every rectangle fits.
  double area = 0;
  for (const SceneQuad& q : scene.quads) {
    area += (q.edge_u.norm() + 2.0 * kPadTexels / 300) * (q.edge_v.norm() + 2.0 * kPadTexels / 300);
  }
  const int S = options.atlas_size;
  double d = std::sqrt(0.92 * S * static_cast<double>(S) / area);
  while (!Pack(&scene.quads, d, S)) d *= 0.97;
  scene.texels_per_m = d;
  scene.atlas = cv::Mat(S, S, CV_8UC3, cv::Scalar(128, 128, 128));
  for (size_t i = 0; i < scene.quads.size(); ++i) {
    SceneQuad& q = scene.quads[i];
    cv::RNG quad_rng(options.seed * 1000003ULL + i * 7919ULL + 17);
    cv::Mat texture = PaintTexture(q, q.atlas_rect.size(), d, quad_rng);
    const bool marked =
        i < structural ? q.kind != SurfaceKind::kDoor : q.kind == SurfaceKind::kPoster;
    if (marked) {
      // The texture spans the quad exactly (texel edges at its edges): its middle is the centre.
      const double radius_px = options.marker_radius_m * q.atlas_rect.width / q.edge_u.norm();
      PaintMarker(&texture, radius_px);
      scene.markers.push_back({q.origin + (q.edge_u + q.edge_v) / 2, q.normal,
                               options.marker_radius_m, static_cast<int>(i)});
    }
    cv::Mat padded;
    cv::copyMakeBorder(texture, padded, kPadTexels, kPadTexels, kPadTexels, kPadTexels,
                       cv::BORDER_REPLICATE);
    padded.copyTo(scene.atlas(q.atlas_rect + cv::Point(-kPadTexels, -kPadTexels) +
                              cv::Size(2 * kPadTexels, 2 * kPadTexels)));
  }

  // The mesh: four vertices per quad, UVs at the texel edges of its rectangle (v up).
  Mesh& mesh = scene.mesh;
  for (const SceneQuad& q : scene.quads) {
    const int base = static_cast<int>(mesh.vertices.size());
    const cv::Rect& r = q.atlas_rect;
    const std::array<Eigen::Vector3d, 4> corners{
        q.origin, q.origin + q.edge_u, q.origin + q.edge_u + q.edge_v, q.origin + q.edge_v};
    const std::array<cv::Point2d, 4> texels{cv::Point2d(r.x, r.y), cv::Point2d(r.x + r.width, r.y),
                                            cv::Point2d(r.x + r.width, r.y + r.height),
                                            cv::Point2d(r.x, r.y + r.height)};
    for (size_t k = 0; k < 4; ++k) {
      mesh.vertices.push_back(corners[k].cast<float>());
      mesh.uvs.emplace_back(static_cast<float>(texels[k].x / S),
                            static_cast<float>(1.0 - texels[k].y / S));
    }
    mesh.triangles.emplace_back(base, base + 1, base + 2);
    mesh.triangles.emplace_back(base, base + 2, base + 3);
  }
  scene.build_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return scene;
}

RayHit CastRay(const CorridorScene& scene, const Eigen::Vector3d& origin,
               const Eigen::Vector3d& direction) {
  RayHit best;
  best.t = std::numeric_limits<double>::infinity();
  for (size_t i = 0; i < scene.quads.size(); ++i) {
    const SceneQuad& q = scene.quads[i];
    const Eigen::Vector3d n = q.edge_u.cross(q.edge_v);
    const double denom = n.dot(direction);
    if (std::abs(denom) < 1e-15) continue;
    const double t = n.dot(q.origin - origin) / denom;
    if (!(t > 1e-9) || t >= best.t) continue;
    const Eigen::Vector3d p = origin + t * direction - q.origin;
    const double a = p.dot(q.edge_u) / q.edge_u.squaredNorm();
    const double c = p.dot(q.edge_v) / q.edge_v.squaredNorm();
    if (a < 0 || a > 1 || c < 0 || c > 1) continue;
    best = {t, static_cast<int>(i)};
  }
  if (best.quad < 0) best.t = 0;
  return best;
}

}  // namespace mm
