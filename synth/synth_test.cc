// The corridor's geometry and the camera paths, without rendering.
#include <gtest/gtest.h>

#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>

#include "dataset/tum.h"
#include "synth/camera_path.h"
#include "synth/corridor.h"
#include "synth/sequence.h"
#include "tests/support/temp_dir.h"

namespace mm {
namespace {

namespace fs = std::filesystem;

fs::path TempDir(const std::string& name) { return test::TestTempPath("synth_unit_" + name); }

// A small sequence (1024^2 atlas, tiny frames): the writer end to end, cheap under emulation.
struct Sequence {
  SynthOptions options;
  SynthSummary summary;
};

Sequence Generate(const std::string& name, const BouguetCamera& camera, CameraPathKind path,
                  int frames, double fps) {
  Sequence s;
  s.options.out = TempDir(name);
  fs::remove_all(s.options.out);
  s.options.camera = camera;
  s.options.frames = frames;
  s.options.fps = fps;
  s.options.path.kind = path;
  s.options.corridor.atlas_size = 1024;
  s.summary = WriteSyntheticSequence(s.options);
  return s;
}

BouguetCamera DistortedCamera() {
  BouguetCamera c = DefaultSynthCamera(96, 72);
  c.alpha_c = 0.002;
  c.kc = {-0.28, 0.11, 0.0012, -0.0009, -0.02};
  return c;
}

CorridorOptions SmallAtlas() {
  CorridorOptions o;
  o.atlas_size = 1024;  // Fast; the geometry does not depend on it.
  return o;
}

TEST(Corridor, SameSeedSameSceneOtherSeedOtherTextures) {
  const CorridorScene a = BuildCorridor(SmallAtlas());
  const CorridorScene b = BuildCorridor(SmallAtlas());
  EXPECT_EQ(cv::norm(a.atlas, b.atlas, cv::NORM_INF), 0.0);
  ASSERT_EQ(a.quads.size(), b.quads.size());
  CorridorOptions other = SmallAtlas();
  other.seed = 2;
  const CorridorScene c = BuildCorridor(other);
  EXPECT_GT(cv::norm(a.atlas, c.atlas, cv::NORM_L1) / a.atlas.total(), 10.0);
  EXPECT_EQ(a.mesh.vertices.size(), 4 * a.quads.size());
  EXPECT_EQ(a.mesh.triangles.size(), 2 * a.quads.size());
  std::cout << "[ figures  ] " << a.quads.size() << " quads, " << a.markers.size() << " markers, "
            << 1000.0 / a.texels_per_m << " mm per texel at 1024^2\n";
}

TEST(Corridor, EveryRequestedFurnishingIsPlaced) {
  const CorridorOptions o = SmallAtlas();
  const CorridorScene s = BuildCorridor(o);
  int doors = 0, posters = 0, box_faces = 0;
  for (const SceneQuad& q : s.quads) {
    doors += q.kind == SurfaceKind::kDoor;
    posters += q.kind == SurfaceKind::kPoster;
    box_faces += q.kind == SurfaceKind::kBox;
  }
  EXPECT_EQ(doors, o.doors);
  EXPECT_EQ(posters, o.posters);
  EXPECT_EQ(box_faces, 5 * o.boxes);
}

TEST(Corridor, MarkersLieOnTheirQuadsAndRaysFindThem) {
  const CorridorScene s = BuildCorridor(SmallAtlas());
  ASSERT_GT(s.markers.size(), 20u);
  for (const SceneMarker& m : s.markers) {
    const SceneQuad& q = s.quads[static_cast<size_t>(m.quad)];
    EXPECT_NEAR(q.normal.dot(m.centre - q.origin), 0.0, 1e-12);
    // A ray from 0.5 m in front of the marker hits that quad 0.5 m away (or something nearer,
    // e.g. a door, when the marker is covered).
    const RayHit hit = CastRay(s, m.centre + 0.5 * m.normal, -m.normal);
    ASSERT_GE(hit.quad, 0);
    EXPECT_LE(hit.t, 0.5 + 1e-12);
    if (hit.quad == m.quad) {
      EXPECT_NEAR(hit.t, 0.5, 1e-12);
    }
  }
}

TEST(Corridor, RayCastsAgainstTheLayout) {
  const CorridorScene s = BuildCorridor(SmallAtlas());
  const CorridorLayout l = LayoutOf(s.options);
  const RayHit down = CastRay(s, {0, 0, 1.6}, {0, 0, -1});
  EXPECT_EQ(s.quads[static_cast<size_t>(down.quad)].kind, SurfaceKind::kFloor);
  EXPECT_NEAR(down.t, 1.6, 1e-12);
  const RayHit up = CastRay(s, {0, 0, 1.6}, {0, 0, 1});
  EXPECT_NEAR(up.t, l.height - 1.6, 1e-12);
  const RayHit back = CastRay(s, {0, 0, 0.1}, {0, -1, 0});  // Below any poster.
  EXPECT_NEAR(back.t, -l.start_y, 1e-12);
}

TEST(CameraPath, RotateNeverTranslatesForwardNeverRotates) {
  const CorridorLayout l = LayoutOf(CorridorOptions{});
  CameraPathOptions rotate;
  rotate.kind = CameraPathKind::kRotate;
  CameraPathOptions forward;
  forward.kind = CameraPathKind::kForward;
  const Eigen::Isometry3d r0 = CameraPoseAt(l, rotate, 0.0, 10.0);
  const Eigen::Isometry3d f0 = CameraPoseAt(l, forward, 0.0, 10.0);
  double max_turn = 0;
  for (double t = 0.1; t <= 10.0; t += 0.1) {
    const Eigen::Isometry3d r = CameraPoseAt(l, rotate, t, 10.0);
    EXPECT_EQ((r.translation() - r0.translation()).norm(), 0.0);
    max_turn = std::max(max_turn, Eigen::AngleAxisd(r.linear() * r0.linear().transpose()).angle());
    const Eigen::Isometry3d f = CameraPoseAt(l, forward, t, 10.0);
    EXPECT_EQ((f.linear() - f0.linear()).norm(), 0.0);
    // Along the optical axis: the motion in the camera frame is (0, 0, +d).
    const Eigen::Vector3d in_cam = f0.linear().transpose() * (f.translation() - f0.translation());
    EXPECT_NEAR(in_cam.head<2>().norm(), 0.0, 1e-12);
    EXPECT_GT(in_cam.z(), 0.0);
  }
  EXPECT_GT(max_turn * 180 / M_PI, 20.0);
}

TEST(CameraPath, WalkGoesAtWalkingPaceAndTurnsTheCorner) {
  const CorridorLayout l = LayoutOf(CorridorOptions{});
  const CameraPathOptions walk;
  const double duration = 16.0;  // Long enough for the corner.
  const Eigen::Isometry3d start = CameraPoseAt(l, walk, 0.0, duration);
  const Eigen::Isometry3d end = CameraPoseAt(l, walk, duration, duration);
  // Starts looking down leg 1 (+y), ends looking down leg 2 (+x), within the head motion.
  EXPECT_GT(start.linear().col(2).dot(Eigen::Vector3d::UnitY()), 0.99);
  EXPECT_GT(end.linear().col(2).dot(Eigen::Vector3d::UnitX()), 0.99);
  EXPECT_NEAR(end.translation().y(), l.outer_y - l.half_width, 0.05);
  double max_speed = 0, min_speed = 1e9, max_rate_deg = 0;
  const double dt = 1.0 / 30;
  for (double t = 0; t + dt <= duration; t += dt) {
    const Eigen::Isometry3d a = CameraPoseAt(l, walk, t, duration);
    const Eigen::Isometry3d b = CameraPoseAt(l, walk, t + dt, duration);
    const double speed = (b.translation() - a.translation()).norm() / dt;
    max_speed = std::max(max_speed, speed);
    min_speed = std::min(min_speed, speed);
    max_rate_deg =
        std::max(max_rate_deg,
                 Eigen::AngleAxisd(b.linear() * a.linear().transpose()).angle() / dt * 180 / M_PI);
    // Inside the corridor, under the ceiling.
    EXPECT_LT(std::abs(a.translation().z() - 1.6), 0.03);
  }
  std::cout << "[ figures  ] walk speed " << min_speed << " .. " << max_speed
            << " m/s, max turn rate " << max_rate_deg << " deg/s\n";
  EXPECT_GT(min_speed, 0.8);
  EXPECT_LT(max_speed, 1.2);
  EXPECT_LT(max_rate_deg, 90.0);
  EXPECT_NEAR(CameraPathLength(l, walk, duration), duration * walk.speed_mps, 1e-9);
}

TEST(SynthOptions, ChecksAndCameraScaling) {
  SynthOptions o;
  EXPECT_NE(o.Check().find("out"), std::string::npos);
  o.out = "/tmp/x";
  EXPECT_EQ(o.Check(), "");
  o.scene = "maze";
  EXPECT_NE(o.Check().find("scene"), std::string::npos);
  BouguetCamera c = DefaultSynthCamera(320, 240);
  EXPECT_DOUBLE_EQ(c.fc.x(), 262.5);
  EXPECT_DOUBLE_EQ(c.cc.x(), 159.5);
  EXPECT_DOUBLE_EQ(c.cc.y(), 119.5);
  // Scaling keeps the rays: a pixel's ray at 640x480 is the scaled pixel's ray at 320x240
  // (pixel edges stay at edges), skew and distortion included.
  c.alpha_c = 0.003;
  c.kc = {-0.2, 0.05, 0.001, 0.002, 0.0};
  const BouguetCamera big = ScaleCamera(c, 640, 480);
  const Eigen::Vector2d ray = c.Unproject(Eigen::Vector2d(100.25, 30.5));
  const Eigen::Vector2d ray_big =
      big.Unproject(Eigen::Vector2d((100.25 + 0.5) * 2 - 0.5, (30.5 + 0.5) * 2 - 0.5));
  EXPECT_LT((ray - ray_big).norm(), 1e-12);
  o.scene = "l-corridor";
  o.fps = 30;
  EXPECT_DOUBLE_EQ(SynthFrameTime(o, 1), 1000.033333);
}

TEST(Synth, SameSeedWritesTheSameBytes) {
  std::vector<std::string> runs;
  for (int run = 0; run < 2; ++run) {
    const Sequence s =
        Generate("same" + std::to_string(run), DistortedCamera(), CameraPathKind::kWalk, 3, 30.0);
    ASSERT_TRUE(s.summary.success) << s.summary.failure_reason;
    std::string bytes;
    for (const char* f : {"rgb.txt", "depth.txt", "groundtruth.txt", "calib.toml"}) {
      std::ifstream in(s.options.out / f, std::ios::binary);
      bytes += std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    }
    for (const TumFrame& f : ReadTumList(s.options.out / "rgb.txt")) {
      std::ifstream in(f.path, std::ios::binary);
      bytes += std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    }
    for (const TumFrame& f : ReadTumList(s.options.out / "depth.txt")) {
      std::ifstream in(f.path, std::ios::binary);
      bytes += std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    }
    runs.push_back(bytes);
    fs::remove_all(s.options.out);
  }
  EXPECT_GT(runs[0].size(), 20000u);
  EXPECT_TRUE(runs[0] == runs[1]) << "two runs with one seed differ";
}

TEST(Synth, RotatePathHasOneCentreForwardPathOneOrientation) {
  for (const CameraPathKind kind : {CameraPathKind::kRotate, CameraPathKind::kForward}) {
    const Sequence s = Generate("path", DefaultSynthCamera(64, 48), kind, 30, 30.0);
    ASSERT_TRUE(s.summary.success) << s.summary.failure_reason;
    const Trajectory t = Trajectory::Read(s.options.out / "groundtruth.txt");
    const Eigen::Isometry3d first = t.poses().front().world_from_cam;
    double moved = 0, turned = 0;
    for (const TimedPose& p : t.poses()) {
      moved = std::max(moved, (p.world_from_cam.translation() - first.translation()).norm());
      turned = std::max(turned, RotationErrorDeg(p.world_from_cam.linear(), first.linear()));
    }
    if (kind == CameraPathKind::kRotate) {
      EXPECT_EQ(moved, 0.0);
      EXPECT_GT(turned, 3.0);
    } else {
      EXPECT_LT(turned, 1e-7);
      EXPECT_GT(moved, 0.9);
    }
    fs::remove_all(s.options.out);
  }
}

}  // namespace
}  // namespace mm
