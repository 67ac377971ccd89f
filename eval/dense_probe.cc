// A developer's probe of the dense depth (recon/dense.h) against TUM's depth of keyframe A:
//   dense_probe DATASET_DIR CALIB OUT_DIR [B_INDEX...]   (pairs (0, b) of keyframes_1hz.txt)
// For each pair: the dense stage's CPU time, the depth map's figures before meshing (shrunk
// image, GT = the median of the 2x2 full-resolution block), the mesh's figures
// (EvaluatePairMesh), the far-off pixels (> 10 %) by class, and PNGs in OUT_DIR: A, the dense
// and the GT inverse depth (one colour scale), the error map and the confidence.
// The environment overrides options (DenseOptions): MM_HOLE max_hole_fraction, MM_CAP
// max_view_disagreement, MM_SNAP edge_snap_min_step, MM_WIN window_radius, MM_BAND
// occlusion_band_px, MM_P1 / MM_P2 penalty_small / penalty_large; (DenseMeshOptions) MM_MINCELL
// min_cell_px. MM_BETWEEN=1 adds the keyframe nearest halfway between as a further view (as the
// pipeline does); MM_GTPOSE=1 sweeps on TUM's ground-truth relative pose instead of the
// estimate (no frame between). It also prints the clean-up's counts and writes where the mesh loses
// pixels the depth map has (lost.png: green where the map was within 10 %, red where it was off).
// Classes, first that applies: out of the sweep's range; B does not see the GT point (outside
// B's image); B sees something nearer there (occluded: a z-buffer of A's GT depth in B); next
// to a GT depth edge (within the window); low texture (A's window std < 4 grey levels); other.
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <string>
#include <vector>

#include "base/clock.h"
#include "base/stats.h"
#include "calib/calib_io.h"
#include "dataset/tum.h"
#include "eval/mesh_checks.h"
#include "recon/dense.h"
#include "recon/pipeline.h"
#include "render/renderer.h"

namespace {

cv::Mat Colorize(const cv::Mat& rho, double lo, double hi) {
  cv::Mat u8(rho.size(), CV_8UC1, cv::Scalar(0));
  for (int y = 0; y < rho.rows; ++y) {
    for (int x = 0; x < rho.cols; ++x) {
      const float v = rho.at<float>(y, x);
      if (v > 0) {
        u8.at<uint8_t>(y, x) =
            static_cast<uint8_t>(std::clamp(1 + 254 * (v - lo) / (hi - lo), 1.0, 255.0));
      }
    }
  }
  cv::Mat c;
  cv::applyColorMap(u8, c, cv::COLORMAP_TURBO);
  c.setTo(cv::Scalar(0, 0, 0), u8 == 0);
  return c;
}

}  // namespace

int main(int argc, char** argv) {
  using namespace mm;
  if (argc < 4) {
    std::fprintf(stderr, "usage: dense_probe DATASET CALIB OUT [b...]\n");
    return 2;
  }
  const std::filesystem::path data = argv[1], out_dir = argv[3];
  std::filesystem::create_directories(out_dir);
  const BouguetCamera camera = LoadCalibration(argv[2]);
  const std::vector<TumFrame> frames = ReadTumList(data / "keyframes_1hz.txt");
  cv::Mat raw = cv::imread((data / "depth/1341847980.723020.png").string(), cv::IMREAD_UNCHANGED);
  cv::Mat gt;
  raw.convertTo(gt, CV_32FC1, 1.0 / 5000.0);
  std::vector<int> bs;
  for (int i = 4; i < argc; ++i) bs.push_back(std::atoi(argv[i]));
  if (bs.empty()) bs = {1, 2, 3};
  const cv::Mat a = cv::imread(frames[0].path.string());
  for (const int ib : bs) {
    const cv::Mat b = cv::imread(frames[static_cast<size_t>(ib)].path.string());
    PairOptions po;
    if (const char* e = std::getenv("MM_HOLE")) po.dense.max_hole_fraction = std::atof(e);
    if (const char* e = std::getenv("MM_CAP")) po.dense.max_view_disagreement = std::atof(e);
    if (const char* e = std::getenv("MM_SNAP")) po.dense.edge_snap_min_step = std::atoi(e);
    if (const char* e = std::getenv("MM_PLANEPX")) po.dense.plane_step_px = std::atof(e);
    if (const char* e = std::getenv("MM_MINCELL")) po.dense_mesh.min_cell_px = std::atoi(e);
    if (const char* e = std::getenv("MM_WIN")) po.dense.window_radius = std::atoi(e);
    if (const char* e = std::getenv("MM_BAND")) po.dense.occlusion_band_px = std::atoi(e);
    if (const char* e = std::getenv("MM_P1")) po.dense.penalty_small = std::atof(e);
    if (const char* e = std::getenv("MM_P2")) po.dense.penalty_large = std::atof(e);
    PairReconstruction r = ReconstructPair(a, b, camera, po);
    if (!r.success) {
      std::printf("(0,%d) failed: %s\n", ib, r.failure_reason.c_str());
      continue;
    }
    const cv::Mat ga = ToGray(a), gb = ToGray(b);
    // MM_BETWEEN=1: the keyframe nearest halfway between 0 and b joins the sweep as in the
    // pipeline (SIFT matches to A, PnP on the pair's points).
    std::vector<DenseView> between;
    if (const char* e = std::getenv("MM_BETWEEN"); e && std::atoi(e) > 0) {
      const Features features_a = ExtractKeyframeFeatures(a, po);
      std::vector<SourceView> offered;
      for (int im = 1; im < ib; ++im) {
        offered.push_back(MatchSourceView(
            features_a, cv::imread(frames[static_cast<size_t>(im)].path.string()), po));
      }
      ChosenSourceViews chosen =
          ChooseSourceViews(offered, r.geometry, r.point_pixels_a, camera.K(), a.size(), po);
      for (const std::string& reason : chosen.left_out) {
        std::printf("  frame between left out: %s\n", reason.c_str());
      }
      between = std::move(chosen.views);
    }
    double t0 = ProcessCpuSeconds();
    // MM_GTPOSE=1: the sweep runs on the ground-truth relative pose (translation scaled to the
    // estimate's length), to separate the pose's share of the depth error from the matching's.
    if (const char* e = std::getenv("MM_GTPOSE"); e && std::atoi(e) > 0) {
      const Trajectory trajectory = Trajectory::Read(data / "groundtruth.txt");
      const auto wa = trajectory.WorldFromCamAt(frames[0].timestamp_s);
      const auto wb = trajectory.WorldFromCamAt(frames[static_cast<size_t>(ib)].timestamp_s);
      if (wa && wb) {
        const Eigen::Isometry3d b_from_a = CamBFromCamA(*wa, *wb);
        r.geometry.rotation = b_from_a.rotation();
        r.geometry.translation =
            b_from_a.translation().normalized() * r.geometry.translation.norm();
        between.clear();  // Their poses are the estimate's.
      }
    }
    DenseDepth d{};
    constexpr int kRuns = 3;
    for (int run = 0; run < kRuns; ++run) {
      d = ComputeDenseDepth(ga, gb, camera.K(), r.geometry.rotation, r.geometry.translation,
                            r.geometry.points_in_cam_a, po.dense, between);
    }
    const double dense_s = (ProcessCpuSeconds() - t0) / kRuns;
    r.mesh = BuildDenseMesh(d, camera.K(), a.cols, a.rows, po.dense_mesh, &r.dense_mesh_summary);
    const MeshDepthEval me = EvaluatePairMesh(r, camera.K(), gt);
    const double scale = ScaleFromPoints(r.geometry.points_in_cam_a, r.point_pixels_a, gt);
    const int f = d.downscale, w = d.inverse_depth.cols, h = d.inverse_depth.rows;
    // GT inverse depth (reconstruction units) per shrunk pixel.
    cv::Mat gt_rho(h, w, CV_32FC1, cv::Scalar(0));
    for (int y = 0; y < h; ++y) {
      for (int x = 0; x < w; ++x) {
        std::vector<float> v;
        for (int j = 0; j < f; ++j) {
          for (int i = 0; i < f; ++i) {
            const float g = gt.at<float>(y * f + j, x * f + i);
            if (g > 0) v.push_back(g);
          }
        }
        if (v.size() < static_cast<size_t>(f * f)) continue;
        std::sort(v.begin(), v.end());
        gt_rho.at<float>(y, x) = static_cast<float>(scale / v[v.size() / 2]);
      }
    }
    // Z-buffer of A's GT points in B (shrunk), in B's depth (units).
    const Eigen::Matrix3d Ks = d.K, Ks_inv = Ks.inverse();
    const Eigen::Matrix3d& R = r.geometry.rotation;
    const Eigen::Vector3d& t = r.geometry.translation;
    cv::Mat zbuf(h, w, CV_32FC1, cv::Scalar(1e30f));
    cv::Mat in_b(h, w, CV_8UC1, cv::Scalar(0));
    cv::Mat zb(h, w, CV_32FC1, cv::Scalar(0));
    cv::Mat ub_map(h, w, CV_32FC2, cv::Scalar(0, 0));
    for (int y = 0; y < h; ++y) {
      for (int x = 0; x < w; ++x) {
        const float g = gt_rho.at<float>(y, x);
        if (!(g > 0)) continue;
        const Eigen::Vector3d X = Ks_inv * Eigen::Vector3d(x, y, 1) / g;
        const Eigen::Vector3d Xb = R * X + t;
        if (Xb.z() <= 0) continue;
        const Eigen::Vector3d pb = Ks * Xb;
        const double ub = pb.x() / pb.z(), vb = pb.y() / pb.z();
        ub_map.at<cv::Vec2f>(y, x) = cv::Vec2f(static_cast<float>(ub), static_cast<float>(vb));
        zb.at<float>(y, x) = static_cast<float>(Xb.z());
        if (ub < 0 || vb < 0 || ub > w - 1 || vb > h - 1) continue;
        in_b.at<uint8_t>(y, x) = 255;
        // Splat 2x2 (a pixel of A covers about a pixel of B).
        for (int j = 0; j <= 1; ++j) {
          for (int i = 0; i <= 1; ++i) {
            const int xx = static_cast<int>(std::floor(ub)) + i,
                      yy = static_cast<int>(std::floor(vb)) + j;
            if (xx < 0 || yy < 0 || xx >= w || yy >= h) continue;
            zbuf.at<float>(yy, xx) = std::min(zbuf.at<float>(yy, xx), static_cast<float>(Xb.z()));
          }
        }
      }
    }
    // Texture and GT edges.
    cv::Mat a8, af, mean, mean2;
    cv::resize(ga, a8, cv::Size(w, h), 0, 0, cv::INTER_AREA);
    a8.convertTo(af, CV_32F);
    const cv::Size win(7, 7);
    cv::boxFilter(af, mean, CV_32F, win);
    cv::boxFilter(af.mul(af), mean2, CV_32F, win);
    cv::Mat stdv;
    cv::sqrt(cv::max(mean2 - mean.mul(mean), 0), stdv);
    cv::Mat edge(h, w, CV_8UC1, cv::Scalar(0));
    for (int y = 0; y < h; ++y) {
      for (int x = 0; x < w; ++x) {
        const float g = gt_rho.at<float>(y, x);
        for (int dy = -1; dy <= 1 && g > 0; ++dy) {
          for (int dx = -1; dx <= 1; ++dx) {
            const int xx = x + dx, yy = y + dy;
            if (xx < 0 || yy < 0 || xx >= w || yy >= h) continue;
            const float o = gt_rho.at<float>(yy, xx);
            if (o > 0 && std::abs(o - g) > 0.1f * std::max(o, g)) edge.at<uint8_t>(y, x) = 255;
          }
        }
      }
    }
    cv::Mat near_edge;
    cv::dilate(edge, near_edge, cv::getStructuringElement(cv::MORPH_RECT, cv::Size(7, 7)));

    enum { kRange, kNotInB, kOccluded, kEdge, kLowTex, kOther, kClasses };
    const char* names[kClasses] = {"out of range",  "outside B",   "occluded in B",
                                   "GT depth edge", "low texture", "other"};
    int count[kClasses] = {}, total_gt = 0, covered = 0;
    int count_far[kClasses] = {}, count_near[kClasses] = {};
    std::vector<double> errs;
    cv::Mat err_vis(h, w, CV_8UC3, cv::Scalar(0, 0, 0));
    cv::Mat cls_vis(h, w, CV_8UC3, cv::Scalar(0, 0, 0));
    const cv::Scalar cls_col[kClasses] = {{255, 0, 255}, {255, 128, 0},   {0, 0, 255},
                                          {0, 255, 255}, {255, 255, 255}, {0, 128, 255}};
    for (int y = 0; y < h; ++y) {
      for (int x = 0; x < w; ++x) {
        const float g = gt_rho.at<float>(y, x);
        if (!(g > 0)) continue;
        ++total_gt;
        const float e_rho = d.inverse_depth.at<float>(y, x);
        if (!(e_rho > 0)) {
          err_vis.at<cv::Vec3b>(y, x) = cv::Vec3b(90, 40, 40);
          continue;
        }
        ++covered;
        const double err = std::abs(g / e_rho - 1.0);  // |z_est - z_gt| / z_gt.
        errs.push_back(err);
        const uint8_t grey = a8.at<uint8_t>(y, x);
        err_vis.at<cv::Vec3b>(y, x) =
            err < 0.05 ? cv::Vec3b(grey / 3, static_cast<uint8_t>(80 + grey / 2), grey / 3)
                       : (err < 0.10 ? cv::Vec3b(0, 200, 255) : cv::Vec3b(0, 0, 255));
        if (err <= 0.10) continue;
        int c = kOther;
        if (g < d.inverse_depth_min || g > d.inverse_depth_max) {
          c = kRange;
        } else if (!in_b.at<uint8_t>(y, x)) {
          c = kNotInB;
        } else {
          const cv::Vec2f ub = ub_map.at<cv::Vec2f>(y, x);
          const int xx = static_cast<int>(std::lround(ub[0])),
                    yy = static_cast<int>(std::lround(ub[1]));
          const float zmin = zbuf.at<float>(std::clamp(yy, 0, h - 1), std::clamp(xx, 0, w - 1));
          if (zb.at<float>(y, x) > 1.05f * zmin) {
            c = kOccluded;
          } else if (near_edge.at<uint8_t>(y, x)) {
            c = kEdge;
          } else if (stdv.at<float>(y, x) < 4.0f) {
            c = kLowTex;
          }
        }
        ++count[c];
        if (e_rho < g)
          ++count_far[c];
        else
          ++count_near[c];
        cls_vis.at<cv::Vec3b>(y, x) =
            cv::Vec3b(static_cast<uint8_t>(cls_col[c][0]), static_cast<uint8_t>(cls_col[c][1]),
                      static_cast<uint8_t>(cls_col[c][2]));
      }
    }
    const double cov = static_cast<double>(covered) / total_gt;
    const size_t off = static_cast<size_t>(
        std::count_if(errs.begin(), errs.end(), [](double e) { return e > 0.1; }));
    std::printf(
        "(0,%d) dense %.3f s CPU, %d planes (rho %.4f..%.4f step %.5f)\n"
        "  depth map: coverage %.3f, median %.4f, p90 %.4f, off %.4f (%zu px)\n"
        "  mesh:      coverage %.3f, median %.4f, p90 %.4f, flying %.4f\n",
        ib, dense_s, d.planes, d.inverse_depth_min, d.inverse_depth_max, d.inverse_depth_step, cov,
        errs.empty() ? 0 : QuantileOf(errs, 0.5), errs.empty() ? 0 : QuantileOf(errs, 0.9),
        static_cast<double>(off) / static_cast<double>(errs.size()), off, me.coverage,
        me.median_rel_err, me.p90_rel_err, me.flying);
    for (int c = 0; c < kClasses; ++c) {
      std::printf("    %-14s %5d (%4.1f %% of off; est. too far %d, too near %d)\n", names[c],
                  count[c], 100.0 * count[c] / std::max<size_t>(1, off), count_far[c],
                  count_near[c]);
    }
    // PNGs.
    double lo = 1e30, hi = 0;
    for (int y = 0; y < h; ++y) {
      for (int x = 0; x < w; ++x) {
        const float g = gt_rho.at<float>(y, x);
        if (g > 0) {
          lo = std::min(lo, static_cast<double>(g));
          hi = std::max(hi, static_cast<double>(g));
        }
      }
    }
    const std::string p = (out_dir / ("p0" + std::to_string(ib) + "_")).string();
    cv::Mat conf8;
    d.confidence.convertTo(conf8, CV_8U, 255.0 / 0.3);
    cv::Mat top, bottom, all;
    cv::Mat a3;
    cv::cvtColor(a8, a3, cv::COLOR_GRAY2BGR);
    cv::Mat conf3;
    cv::cvtColor(conf8, conf3, cv::COLOR_GRAY2BGR);
    cv::hconcat(
        std::vector<cv::Mat>{a3, Colorize(d.inverse_depth, lo, hi), Colorize(gt_rho, lo, hi)}, top);
    cv::hconcat(std::vector<cv::Mat>{err_vis, cls_vis, conf3}, bottom);
    cv::vconcat(top, bottom, all);
    cv::imwrite(p + "panel.png", all);
    cv::imwrite(p + "a.png", a8);
    auto big = [](const cv::Mat& m) {
      cv::Mat o;
      cv::resize(m, o, cv::Size(), 2, 2, cv::INTER_NEAREST);
      return o;
    };
    cv::imwrite(p + "err.png", big(err_vis));
    cv::imwrite(p + "cls.png", big(cls_vis));
    cv::imwrite(p + "est.png", big(Colorize(d.inverse_depth, lo, hi)));
    cv::imwrite(p + "gt.png", big(Colorize(gt_rho, lo, hi)));
    cv::Mat b8;
    cv::resize(gb, b8, cv::Size(w, h), 0, 0, cv::INTER_AREA);
    cv::imwrite(p + "b.png", b8);
    std::printf("  clean-up: cut to outlines %d, filled in holes %d, occlusion bands %d\n",
                d.cut_to_outlines, d.filled_in_holes, d.dropped_in_occlusion_bands);
    // Where the mesh loses the map: full-resolution pixels with GT whose shrunk pixel has a
    // depth but the rendered mesh none.
    Renderer renderer;
    RenderCamera cam;
    cam.K = camera.K();
    cam.width = gt.cols;
    cam.height = gt.rows;
    cam.near_plane = 1e-3;
    cam.far_plane = 1e3;
    const RenderResult rendered = renderer.Render(r.mesh, cv::Mat(), cam);
    cv::Mat lost(gt.size(), CV_8UC3, cv::Scalar(0, 0, 0));
    int lost_right = 0, lost_off = 0;
    for (int y = 0; y < gt.rows; ++y) {
      for (int x = 0; x < gt.cols; ++x) {
        const uint8_t grey = a.at<cv::Vec3b>(y, x)[1];
        lost.at<cv::Vec3b>(y, x) = cv::Vec3b(grey / 3, grey / 3, grey / 3);
        const float e_rho =
            d.inverse_depth.at<float>(std::min(y / f, h - 1), std::min(x / f, w - 1));
        if (!(gt.at<float>(y, x) > 0) || !(e_rho > 0) || !rendered.success ||
            rendered.depth.at<float>(y, x) > 0) {
          continue;
        }
        const bool far_off = std::abs(scale / gt.at<float>(y, x) / e_rho - 1.0) > 0.1;
        ++(far_off ? lost_off : lost_right);
        lost.at<cv::Vec3b>(y, x) = far_off ? cv::Vec3b(0, 0, 255) : cv::Vec3b(0, 255, 0);
      }
    }
    std::printf("  the mesh loses %d px the map had within 10 %%, %d it had off\n", lost_right,
                lost_off);
    cv::imwrite(p + "lost.png", lost);
  }
  return 0;
}
