#include "synth/sequence.h"

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <system_error>
#include <vector>

#include "calib/calib_io.h"
#include "calib/calib_results_m.h"
#include "render/renderer.h"

namespace mm {
namespace {

using Clock = std::chrono::steady_clock;
double Since(Clock::time_point t) {
  return std::chrono::duration<double>(Clock::now() - t).count();
}

constexpr double kNear = 0.05, kFar = 30.0;  // Metres; the corridor's longest view is ~13 m.
constexpr double kDepthScale = 5000.0;       // TUM: depth PNG value / 5000 = metres.

std::string TimeString(double t) {
  char buf[64];
  std::snprintf(buf, sizeof(buf), "%.6f", t);
  return buf;
}

// Resampling of a finer pinhole render into the distorted image: for every output pixel, where
// its ray lands in the pinhole image.
struct DistortionMaps {
  BouguetCamera pinhole;  // No distortion, no skew; fc = render_scale * fc.
  cv::Mat map_x, map_y;   // CV_32FC1, output size.
};

DistortionMaps MakeDistortionMaps(const BouguetCamera& camera, double scale) {
  const int w = camera.width, h = camera.height;
  std::vector<Eigen::Vector2d> rays(static_cast<size_t>(w) * static_cast<size_t>(h));
  Eigen::Vector2d lo(1e9, 1e9), hi(-1e9, -1e9);
  for (int v = 0; v < h; ++v) {
    for (int u = 0; u < w; ++u) {
      const Eigen::Vector2d x_n = camera.Unproject(Eigen::Vector2d(u, v));
      rays[static_cast<size_t>(v) * w + u] = x_n;
      lo = lo.cwiseMin(x_n);
      hi = hi.cwiseMax(x_n);
    }
  }
  DistortionMaps m;
  m.pinhole.fc = camera.fc * scale;
  const int margin = 2;  // Pixels around the outermost ray (bilinear needs the next pixel).
  m.pinhole.cc =
      Eigen::Vector2d(margin - lo.x() * m.pinhole.fc.x(), margin - lo.y() * m.pinhole.fc.y());
  m.pinhole.width =
      static_cast<int>(std::ceil((hi.x() - lo.x()) * m.pinhole.fc.x())) + 2 * margin + 1;
  m.pinhole.height =
      static_cast<int>(std::ceil((hi.y() - lo.y()) * m.pinhole.fc.y())) + 2 * margin + 1;
  m.map_x.create(h, w, CV_32FC1);
  m.map_y.create(h, w, CV_32FC1);
  for (int v = 0; v < h; ++v) {
    for (int u = 0; u < w; ++u) {
      const Eigen::Vector2d p = m.pinhole.PixelFromDistorted(rays[static_cast<size_t>(v) * w + u]);
      m.map_x.at<float>(v, u) = static_cast<float>(p.x());
      m.map_y.at<float>(v, u) = static_cast<float>(p.y());
    }
  }
  return m;
}

// Depth through the maps: z is the same in both images (one camera frame). On a plane 1/z is
// affine in the pinhole image, so bilinear 1/z is exact there; where the four samples are not on
// one plane (1/z not affine within 1e-4: a depth edge, a crease) or one is empty, the nearest
// sample is taken instead.
cv::Mat ResampleDepth(const cv::Mat& depth, const cv::Mat& map_x, const cv::Mat& map_y) {
  cv::Mat out(map_x.size(), CV_32FC1, cv::Scalar(0));
  const int w = depth.cols, h = depth.rows;
  for (int v = 0; v < out.rows; ++v) {
    for (int u = 0; u < out.cols; ++u) {
      const double x = map_x.at<float>(v, u), y = map_y.at<float>(v, u);
      const int x0 = static_cast<int>(std::floor(x)), y0 = static_cast<int>(std::floor(y));
      if (x0 < 0 || y0 < 0 || x0 + 1 >= w || y0 + 1 >= h) continue;
      const double fx = x - x0, fy = y - y0;
      const double d[4] = {depth.at<float>(y0, x0), depth.at<float>(y0, x0 + 1),
                           depth.at<float>(y0 + 1, x0), depth.at<float>(y0 + 1, x0 + 1)};
      const double nearest = d[(fy >= 0.5 ? 2 : 0) + (fx >= 0.5 ? 1 : 0)];
      if (!(d[0] > 0 && d[1] > 0 && d[2] > 0 && d[3] > 0)) {
        out.at<float>(v, u) = static_cast<float>(nearest);
        continue;
      }
      const double inv[4] = {1 / d[0], 1 / d[1], 1 / d[2], 1 / d[3]};
      const double lo = std::min({inv[0], inv[1], inv[2], inv[3]});
      const double hi = std::max({inv[0], inv[1], inv[2], inv[3]});
      const bool planar =
          std::abs(inv[0] + inv[3] - inv[1] - inv[2]) <= 1e-4 * hi && hi < 1.25 * lo;
      if (planar) {
        const double i = (1 - fx) * (1 - fy) * inv[0] + fx * (1 - fy) * inv[1] +
                         (1 - fx) * fy * inv[2] + fx * fy * inv[3];
        out.at<float>(v, u) = static_cast<float>(1.0 / i);
      } else {
        out.at<float>(v, u) = static_cast<float>(nearest);
      }
    }
  }
  return out;
}

cv::Mat DepthPng(const cv::Mat& depth_m) {
  cv::Mat out(depth_m.size(), CV_16UC1);
  for (int v = 0; v < depth_m.rows; ++v) {
    const float* src = depth_m.ptr<float>(v);
    uint16_t* dst = out.ptr<uint16_t>(v);
    for (int u = 0; u < depth_m.cols; ++u) {
      const double value = std::round(src[u] * kDepthScale);
      dst[u] = (src[u] > 0 && value <= 65535.0) ? static_cast<uint16_t>(value) : 0;
    }
  }
  return out;
}

}  // namespace

std::string SynthOptions::Check() const {
  if (out.empty()) return "out: required";
  if (scene != "l-corridor") return "scene: unknown '" + scene + "' (known: l-corridor)";
  if (frames <= 0) return "frames: must be > 0";
  if (!(fps > 0 && fps <= 1000)) return "fps: must be in (0, 1000]";
  if (!(start_time_s >= 0 && start_time_s < 1e10)) return "start_time_s: must be in [0, 1e10)";
  if (camera.width > 0 || camera.height > 0) {
    if (camera.width < 16 || camera.height < 16 || camera.width > 8192 || camera.height > 8192) {
      return "camera: image size must be within 16..8192";
    }
    if (const std::string problem = camera.Check(); !problem.empty()) return "camera." + problem;
  }
  if (!(render_scale >= 1.0 && render_scale <= 4.0)) return "render_scale: must be in [1, 4]";
  if (png_compression < 0 || png_compression > 9) return "png_compression: must be in [0, 9]";
  if (const std::string problem = corridor.Check(); !problem.empty()) return "corridor." + problem;
  if (const std::string problem = path.Check(); !problem.empty()) return "path." + problem;
  return {};
}

BouguetCamera DefaultSynthCamera(int width, int height) {
  BouguetCamera c;
  c.fc = Eigen::Vector2d(525.0, 525.0);
  c.cc = Eigen::Vector2d(319.5, 239.5);
  c.width = 640;
  c.height = 480;
  return ScaleCamera(c, width, height);
}

BouguetCamera ScaleCamera(const BouguetCamera& camera, int width, int height) {
  if (camera.width == width && camera.height == height) return camera;
  BouguetCamera c = camera;
  const double sx = static_cast<double>(width) / camera.width;
  const double sy = static_cast<double>(height) / camera.height;
  c.fc = Eigen::Vector2d(camera.fc.x() * sx, camera.fc.y() * sy);
  // Pixel centres at integers: the image's edge (-0.5) stays at the edge.
  c.cc = Eigen::Vector2d((camera.cc.x() + 0.5) * sx - 0.5, (camera.cc.y() + 0.5) * sy - 0.5);
  // alpha_c is relative to fc1 (KK(0,1) = alpha_c fc1): unchanged.
  c.error.reset();
  c.width = width;
  c.height = height;
  return c;
}

double SynthFrameTime(const SynthOptions& options, int i) {
  return std::strtod(TimeString(options.start_time_s + i / options.fps).c_str(), nullptr);
}

SynthSummary WriteSyntheticSequence(const SynthOptions& options) {
  const auto start = Clock::now();
  SynthSummary s;
  if (const std::string problem = options.Check(); !problem.empty()) {
    s.failure_reason = "options: " + problem;
    return s;
  }
  const BouguetCamera camera = options.camera.width > 0 ? options.camera : DefaultSynthCamera();
  namespace fs = std::filesystem;
  std::error_code ec;
  fs::create_directories(options.out / "rgb", ec);
  if (!ec) fs::create_directories(options.out / "depth", ec);
  if (ec) {
    s.failure_reason = "cannot create " + options.out.string() + ": " + ec.message();
    return s;
  }

  const CorridorScene scene = BuildCorridor(options.corridor);
  s.scene_s = scene.build_s;
  s.quads = static_cast<int>(scene.quads.size());
  s.triangles = static_cast<int>(scene.mesh.triangles.size());
  s.texels_per_m = scene.texels_per_m;
  const CorridorLayout layout = LayoutOf(options.corridor);
  s.duration_s = options.frames / options.fps;
  s.path_length_m = CameraPathLength(layout, options.path, s.duration_s);

  const auto setup = Clock::now();
  Renderer renderer;
  if (!renderer.ok()) {
    s.failure_reason = renderer.error();
    return s;
  }
  s.gl_renderer = renderer.gl_renderer();
  UploadOptions upload;
  upload.mipmaps = true;  // The far floor and ceiling are seen strongly minified.
  std::string error;
  const int mesh_id = renderer.Upload(scene.mesh, scene.atlas, upload, &error);
  if (mesh_id < 0) {
    s.failure_reason = error;
    return s;
  }
  s.distorted = camera.HasDistortion();
  RenderCamera rc;
  rc.near_plane = kNear;
  rc.far_plane = kFar;
  DistortionMaps maps;
  if (s.distorted) {
    maps = MakeDistortionMaps(camera, options.render_scale);
    rc.K = maps.pinhole.K();
    rc.width = maps.pinhole.width;
    rc.height = maps.pinhole.height;
  } else {
    rc.K = camera.K();
    rc.width = camera.width;
    rc.height = camera.height;
  }
  s.render_width = rc.width;
  s.render_height = rc.height;
  s.setup_s = Since(setup);

  std::ofstream rgb_list(options.out / "rgb.txt"), depth_list(options.out / "depth.txt"),
      gt(options.out / "groundtruth.txt");
  const std::string header = "# monomesh synth: scene " + options.scene + ", path " +
                             CameraPathName(options.path.kind) + ", seed " +
                             std::to_string(options.corridor.seed) + "\n";
  rgb_list << "# color images\n" << header << "# timestamp filename\n";
  depth_list << "# depth maps (value / 5000 = metres, 0 = none)\n"
             << header << "# timestamp filename\n";
  gt << "# ground truth trajectory (world_from_cam, exact)\n"
     << header << "# timestamp tx ty tz qx qy qz qw\n";
  const std::vector<int> png_params{cv::IMWRITE_PNG_COMPRESSION, options.png_compression};
  for (int i = 0; i < options.frames; ++i) {
    const auto frame_start = Clock::now();
    const double t = SynthFrameTime(options, i);
    const std::string stamp = TimeString(t);
    const Eigen::Isometry3d world_from_cam =
        CameraPoseAt(layout, options.path, t - options.start_time_s, s.duration_s);
    rc.cam_from_world = world_from_cam.inverse();
    RenderResult r = renderer.Draw(mesh_id, rc);
    if (!r.success) {
      s.failure_reason = "frame " + std::to_string(i) + ": " + r.failure_reason;
      return s;
    }
    cv::Mat rgb = r.rgb, depth = r.depth;
    if (s.distorted) {
      cv::remap(r.rgb, rgb, maps.map_x, maps.map_y, cv::INTER_LINEAR, cv::BORDER_CONSTANT);
      depth = ResampleDepth(r.depth, maps.map_x, maps.map_y);
    }
    const auto write_start = Clock::now();
    s.render_s += std::chrono::duration<double>(write_start - frame_start).count();
    const std::string rgb_file = "rgb/" + stamp + ".png", depth_file = "depth/" + stamp + ".png";
    if (!cv::imwrite((options.out / rgb_file).string(), rgb, png_params) ||
        !cv::imwrite((options.out / depth_file).string(), DepthPng(depth), png_params)) {
      s.failure_reason = "cannot write " + (options.out / rgb_file).string();
      return s;
    }
    rgb_list << stamp << " " << rgb_file << "\n";
    depth_list << stamp << " " << depth_file << "\n";
    Eigen::Quaterniond q(world_from_cam.linear());
    q.normalize();
    if (q.w() < 0) q.coeffs() = -q.coeffs();
    const Eigen::Vector3d p = world_from_cam.translation();
    char line[256];
    std::snprintf(line, sizeof(line), "%s %.10f %.10f %.10f %.12f %.12f %.12f %.12f\n",
                  stamp.c_str(), p.x(), p.y(), p.z(), q.x(), q.y(), q.z(), q.w());
    gt << line;
    s.write_s += Since(write_start);
    ++s.frames;
  }
  std::ofstream(options.out / "calib.toml") << FormatCalibrationToml(camera);
  CalibResults results;
  results.camera = camera;
  std::ofstream(options.out / "Calib_Results.m") << FormatCalibResultsM(results);
  rgb_list.close();
  depth_list.close();
  gt.close();
  if (!rgb_list || !depth_list || !gt) {
    s.failure_reason = "cannot write the lists in " + options.out.string();
    return s;
  }
  s.total_s = Since(start);
  s.success = true;
  return s;
}

}  // namespace mm
