// The mesh against real pixels and ground truth, on the bundled TUM fr3 keyframes (pairs
// (0,2) and (0,3); keyframe 0 has TUM's depth map): the textured mesh rendered from camera A
// must look like keyframe A, from camera B like keyframe B, and its depth must match TUM's
// depth after the scale given by the triangulated points (not fitted to the mesh).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <opencv2/imgcodecs.hpp>

#include "calib/calib_io.h"
#include "dataset/tum.h"
#include "recon/mesh.h"
#include "recon/pipeline.h"
#include "eval/mesh_checks.h"
#include "render/renderer.h"

namespace mm {
namespace {

const std::filesystem::path kOffice = std::filesystem::path(MM_SOURCE_DIR) / "data/tum_office";

struct PairFigures {
  double ncc_a = 0, ncc_b = 0, coverage_b = 0;
  MeshDepthEval depth;
};

class MeshQuality : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    renderer_ = new Renderer();
    camera_ = LoadCalibration(kOffice / "calib.toml");
    frames_ = ReadTumList(kOffice / "rgb.txt");
    const cv::Mat raw =
        cv::imread((kOffice / "depth/1341847980.723020.png").string(), cv::IMREAD_UNCHANGED);
    raw.convertTo(gt_depth_, CV_32FC1, 1.0 / 5000.0);  // TUM: depth[m] = value / 5000.
  }
  static void TearDownTestSuite() {
    delete renderer_;
    renderer_ = nullptr;
  }

  static cv::Mat Image(int i) { return cv::imread(frames_[static_cast<size_t>(i)].path.string()); }

  // Renders `mesh` from A and from B (the estimated pose) and evaluates A's depth.
  static PairFigures Evaluate(const Mesh& mesh, const PairReconstruction& r, const cv::Mat& a,
                              const cv::Mat& b) {
    PairFigures f;
    RenderCamera cam;
    cam.K = camera_.K();
    cam.width = a.cols;
    cam.height = a.rows;
    cam.far_plane = 1000;
    const RenderResult from_a = renderer_->Render(mesh, a, cam);
    EXPECT_TRUE(from_a.success) << from_a.failure_reason;
    if (from_a.success) f.ncc_a = MaskedNcc(from_a.rgb, a, from_a.mask);
    cam.cam_from_world.linear() = r.geometry.rotation;
    cam.cam_from_world.translation() = r.geometry.translation;
    const RenderResult from_b = renderer_->Render(mesh, a, cam);
    EXPECT_TRUE(from_b.success) << from_b.failure_reason;
    if (from_b.success) {
      f.ncc_b = MaskedNcc(from_b.rgb, b, from_b.mask);
      f.coverage_b = static_cast<double>(from_b.covered_pixels) / (a.cols * a.rows);
    }
    RenderCamera cam_a;
    cam_a.K = camera_.K();
    cam_a.width = a.cols;
    cam_a.height = a.rows;
    const double scale =
        ScaleFromPoints(r.geometry.points_in_cam_a, r.point_pixels_a, gt_depth_);
    f.depth = EvaluateMeshDepth(*renderer_, mesh, cam_a, gt_depth_, scale);
    return f;
  }

  static Renderer* renderer_;
  static BouguetCamera camera_;
  static std::vector<TumFrame> frames_;
  static cv::Mat gt_depth_;
};
Renderer* MeshQuality::renderer_ = nullptr;
BouguetCamera MeshQuality::camera_;
std::vector<TumFrame> MeshQuality::frames_;
cv::Mat MeshQuality::gt_depth_;

TEST_F(MeshQuality, TumPairsMeetTheIssueThresholds) {
  ASSERT_TRUE(renderer_->ok()) << renderer_->error();
  ASSERT_FALSE(gt_depth_.empty());
  for (int ib : {2, 3}) {
    SCOPED_TRACE("pair (0," + std::to_string(ib) + ")");
    const cv::Mat a = Image(0), b = Image(ib);
    const PairReconstruction r = ReconstructPair(a, b, camera_, PairOptions{});
    ASSERT_TRUE(r.success) << r.failure_reason;
    const PairFigures f = Evaluate(r.mesh, r, a, b);
    ASSERT_TRUE(f.depth.success) << f.depth.failure_reason;
    // The floor under the mesh's error: the triangulated points' own error, same scale.
    const double scale = ScaleFromPoints(r.geometry.points_in_cam_a, r.point_pixels_a, gt_depth_);
    std::vector<double> point_err;
    for (size_t i = 0; i < r.point_pixels_a.size(); ++i) {
      const cv::Point px(static_cast<int>(std::lround(r.point_pixels_a[i].x())),
                         static_cast<int>(std::lround(r.point_pixels_a[i].y())));
      const float gt = gt_depth_.at<float>(px);
      if (gt > 0) point_err.push_back(std::abs(scale * r.geometry.points_in_cam_a[i].z() - gt) / gt);
    }
    std::sort(point_err.begin(), point_err.end());
    if (!point_err.empty()) {
      std::printf("pair (0,%d): scale %.4f m/unit; points vs GT: median %.4f over %zu points\n", ib,
                  scale, point_err[point_err.size() / 2], point_err.size());
    }
    std::printf(
        "pair (0,%d): %d points, %d vertices, %d triangles (dropped: %d depth, %d grazing); "
        "NCC A %.4f, NCC B %.4f (B coverage %.3f); depth coverage %.3f, median %.4f, p90 "
        "%.4f\n",
        ib, r.mesh_summary.input_points, r.mesh_summary.vertices, r.mesh_summary.triangles,
        r.mesh_summary.dropped_depth_discontinuity, r.mesh_summary.dropped_grazing_angle,
        f.ncc_a, f.ncc_b, f.coverage_b, f.depth.coverage, f.depth.median_rel_err,
        f.depth.p90_rel_err);
    // Issue 5's thresholds. Measured with the defaults: (0,2) NCC A 0.992, B 0.979, depth
    // coverage 0.596, median 2.37 %, p90 12.8 %; (0,3) 0.988, 0.931, 0.513, 3.50 %, 21.2 %.
    EXPECT_GE(f.ncc_a, 0.95);
    EXPECT_GE(f.ncc_b, 0.7);
    EXPECT_LE(f.depth.median_rel_err, 0.05);
    EXPECT_GE(f.depth.coverage, 0.40);
    // The one-call form for `monomesh eval` gives the same figures.
    const MeshDepthEval e = EvaluatePairMesh(r, camera_.K(), gt_depth_);
    ASSERT_TRUE(e.success) << e.failure_reason;
    EXPECT_NEAR(e.median_rel_err, f.depth.median_rel_err, 1e-9);
    EXPECT_NEAR(e.coverage, f.depth.coverage, 1e-9);
  }
}

// The dense mesh (the default) against the sparse one on the same pairs: it must beat it on
// coverage, median and p90 depth error and the flying share, and look like B from B.
TEST_F(MeshQuality, DenseMeshBeatsSparseOnEveryFigure) {
  ASSERT_TRUE(renderer_->ok()) << renderer_->error();
  for (int ib : {2, 3}) {
    SCOPED_TRACE("pair (0," + std::to_string(ib) + ")");
    const cv::Mat a = Image(0), b = Image(ib);
    PairOptions sparse_options;
    sparse_options.mesh_mode = MeshMode::kSparse;
    const PairReconstruction sparse = ReconstructPair(a, b, camera_, sparse_options);
    const PairReconstruction dense = ReconstructPair(a, b, camera_, PairOptions{});
    ASSERT_TRUE(sparse.success && dense.success);
    ASSERT_EQ(dense.mesh_mode, MeshMode::kDense) << dense.dense_failure_reason;
    const PairFigures fs = Evaluate(sparse.mesh, sparse, a, b);
    const PairFigures fd = Evaluate(dense.mesh, dense, a, b);
    ASSERT_TRUE(fs.depth.success && fd.depth.success);
    std::printf(
        "pair (0,%d) sparse: %zu vertices, coverage %.3f, median %.4f, p90 %.4f, flying %.4f, "
        "NCC B %.4f\npair (0,%d) dense:  %zu vertices, coverage %.3f, median %.4f, p90 %.4f, "
        "flying %.4f, NCC B %.4f (dense %.3f s, %d planes, %.3f of A with depth)\n",
        ib, sparse.mesh.vertices.size(), fs.depth.coverage, fs.depth.median_rel_err,
        fs.depth.p90_rel_err, fs.depth.flying, fs.ncc_b, ib, dense.mesh.vertices.size(),
        fd.depth.coverage, fd.depth.median_rel_err, fd.depth.p90_rel_err, fd.depth.flying,
        fd.ncc_b, dense.times.dense_s, dense.dense_planes, dense.dense_valid_fraction);
    EXPECT_GT(fd.depth.coverage, fs.depth.coverage);
    EXPECT_LT(fd.depth.median_rel_err, fs.depth.median_rel_err);
    EXPECT_LT(fd.depth.p90_rel_err, fs.depth.p90_rel_err);
    EXPECT_LT(fd.depth.flying, fs.depth.flying);
    // Measured: (0,2) coverage 0.818, median 1.76 %, p90 6.6 %, flying 4.8 %; (0,3) 0.788,
    // 1.96 %, 8.7 %, 8.2 %.
    EXPECT_GE(fd.depth.coverage, ib == 2 ? 0.80 : 0.77);
    EXPECT_LE(fd.depth.median_rel_err, 0.022);
    EXPECT_LE(fd.depth.p90_rel_err, 0.095);
    EXPECT_LE(fd.depth.flying, 0.095);
    EXPECT_GE(fd.ncc_b, 0.90);
    EXPECT_LE(dense.mesh.vertices.size(), static_cast<size_t>(DenseMeshOptions{}.vertex_budget));
  }
}

// The keyframes between A and B as further views of the sweep (as the daemon passes the gate's
// frame about halfway): (0,2) with keyframe 1, (0,3) with keyframes 1 and 2 offered (the nearer
// to halfway taken), their correspondences with A by SIFT matching.
TEST_F(MeshQuality, AFrameBetweenRaisesCoverageAndLowersTheFarOffShare) {
  ASSERT_TRUE(renderer_->ok()) << renderer_->error();
  for (int ib : {2, 3}) {
    SCOPED_TRACE("pair (0," + std::to_string(ib) + ")");
    const cv::Mat a = Image(0), b = Image(ib);
    const PairOptions options;
    const Features features_a = ExtractKeyframeFeatures(a, options);
    std::vector<SourceView> between;
    for (int im = 1; im < ib; ++im)
      between.push_back(MatchSourceView(features_a, Image(im), options));
    const PairReconstruction two = ReconstructPair(a, b, camera_, options);
    const PairReconstruction three = ReconstructPair(a, b, camera_, options, between);
    ASSERT_TRUE(two.success && three.success);
    ASSERT_EQ(three.mesh_mode, MeshMode::kDense) << three.dense_failure_reason;
    EXPECT_EQ(three.intermediate_views, ib - 1);
    EXPECT_EQ(three.intermediate_views_used, 1);
    // Every frame was posed; one left out is outside 20-80 % of B's distance from A.
    for (const std::string& reason : three.intermediate_failures) {
      std::printf("pair (0,%d): frame between left out: %s\n", ib, reason.c_str());
      EXPECT_NE(reason.find("of B's distance from A"), std::string::npos) << reason;
    }
    const PairFigures f2 = Evaluate(two.mesh, two, a, b);
    const PairFigures f3 = Evaluate(three.mesh, three, a, b);
    ASSERT_TRUE(f2.depth.success && f3.depth.success);
    std::printf(
        "pair (0,%d) A,B: coverage %.3f, median %.4f, p90 %.4f, flying %.4f, NCC B %.4f; "
        "with a frame between: coverage %.3f, median %.4f, p90 %.4f, flying %.4f, NCC B "
        "%.4f (dense %.3f s)\n",
        ib, f2.depth.coverage, f2.depth.median_rel_err, f2.depth.p90_rel_err, f2.depth.flying,
        f2.ncc_b, f3.depth.coverage, f3.depth.median_rel_err, f3.depth.p90_rel_err, f3.depth.flying,
        f3.ncc_b, three.times.dense_s);
    // Measured: (0,2) coverage 0.818 -> 0.858, median 1.76 -> 1.75 %, p90 6.63 -> 6.68 %,
    // flying 4.78 -> 4.84 %; (0,3) 0.788 -> 0.851, 1.96 -> 1.67 %, 8.7 -> 6.7 %, 8.2 -> 4.7 %.
    // On (0,2) B already sees most of A, so the frame between adds coverage at the same share
    // of far-off pixels; on (0,3) it also settles what B does not see.
    EXPECT_GE(f3.depth.coverage, 0.85);
    EXPECT_GT(f3.depth.coverage, f2.depth.coverage + 0.015);
    EXPECT_LE(f3.depth.flying, f2.depth.flying + 0.003);
    EXPECT_LE(f3.depth.p90_rel_err, f2.depth.p90_rel_err + 0.001);
    if (ib == 3) {
      EXPECT_LT(f3.depth.flying, f2.depth.flying - 0.015);
      EXPECT_LT(f3.depth.p90_rel_err, f2.depth.p90_rel_err - 0.01);
    }
    EXPECT_LE(f3.depth.median_rel_err, 0.02);
    EXPECT_LE(f3.depth.p90_rel_err, 0.075);
    EXPECT_LE(f3.depth.flying, 0.05);
    EXPECT_GE(f3.ncc_b, 0.90);
  }
}

// Not a threshold test: prints the figures per meshing option (the measurement behind the
// defaults in MeshOptions), and checks that each variant still builds a usable mesh.
TEST_F(MeshQuality, MeshingOptionSweep) {
  ASSERT_TRUE(renderer_->ok()) << renderer_->error();
  struct Variant {
    const char* name;
    MeshOptions options;
  };
  std::vector<Variant> variants;
  auto add = [&variants](const char* name, auto&& edit) {
    MeshOptions o;
    edit(o);
    variants.push_back({name, o});
  };
  add("defaults", [](MeshOptions&) {});
  add("no voxel grid, no filters", [](MeshOptions& o) {
    o.voxel_size = -1;
    o.max_depth_ratio = 0;
    o.max_grazing_angle_deg = 0;
  });
  add("no voxel grid", [](MeshOptions& o) { o.voxel_size = -1; });
  add("thesis: centre, >=3 pts, no filters", [](MeshOptions& o) {
    o.voxel_vertex = VoxelVertex::kCellCentre;
    o.min_points_per_cell = 3;
    o.max_depth_ratio = 0;
    o.max_grazing_angle_deg = 0;
  });
  add("centre, >=3", [](MeshOptions& o) {
    o.voxel_vertex = VoxelVertex::kCellCentre;
    o.min_points_per_cell = 3;
  });
  add("centroid, >=3", [](MeshOptions& o) { o.min_points_per_cell = 3; });
  add("centroid, >=2", [](MeshOptions& o) { o.min_points_per_cell = 2; });
  add("centre, >=1", [](MeshOptions& o) { o.voxel_vertex = VoxelVertex::kCellCentre; });
  add("fraction 1/24", [](MeshOptions& o) { o.voxel_auto_fraction = 1.0 / 24; });
  add("fraction 1/96", [](MeshOptions& o) { o.voxel_auto_fraction = 1.0 / 96; });
  add("fraction 1/200", [](MeshOptions& o) { o.voxel_auto_fraction = 1.0 / 200; });
  add("depth ratio off", [](MeshOptions& o) { o.max_depth_ratio = 0; });
  add("depth ratio 1.15", [](MeshOptions& o) { o.max_depth_ratio = 1.15; });
  add("depth ratio 1.2", [](MeshOptions& o) { o.max_depth_ratio = 1.2; });
  add("depth ratio 1.25", [](MeshOptions& o) { o.max_depth_ratio = 1.25; });
  add("depth ratio 1.6", [](MeshOptions& o) { o.max_depth_ratio = 1.6; });
  add("grazing off", [](MeshOptions& o) { o.max_grazing_angle_deg = 0; });
  add("grazing 75", [](MeshOptions& o) { o.max_grazing_angle_deg = 75; });
  for (int ib : {2, 3}) {
    const cv::Mat a = Image(0), b = Image(ib);
    const PairReconstruction r = ReconstructPair(a, b, camera_, PairOptions{});
    ASSERT_TRUE(r.success) << r.failure_reason;
    for (const Variant& v : variants) {
      MeshSummary s;
      const Mesh mesh = BuildDelaunayMesh(r.geometry.points_in_cam_a, camera_.K(), a.cols,
                                          a.rows, v.options, &s);
      const PairFigures f = Evaluate(mesh, r, a, b);
      std::printf(
          "sweep (0,%d) %-36s cell %.4f verts %5d tris %5d drop d%4d g%4d | NCC A %.4f B "
          "%.4f | cov %.3f med %.4f p90 %.4f\n",
          ib, v.name, s.voxel_size, s.vertices, s.triangles, s.dropped_depth_discontinuity,
          s.dropped_grazing_angle, f.ncc_a, f.ncc_b, f.depth.coverage, f.depth.median_rel_err,
          f.depth.p90_rel_err);
      // With a few hundred points, cells of >= 2-3 points are rare (the thesis' rule leaves
      // 0-3 vertices here, measured); every variant keeping single-point cells must mesh.
      if (v.options.min_points_per_cell == 1) {
        EXPECT_GT(s.triangles, 100) << v.name;
      }
    }
  }
}

}  // namespace
}  // namespace mm
