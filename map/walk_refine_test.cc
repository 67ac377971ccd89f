#include "map/walk_refine.h"

#include <gtest/gtest.h>

#include <random>
#include <vector>

namespace mm {
namespace {

// A wall of points 3-6 m in front of 20 keyframes on a 2 m line, seen with 0.3 px of noise;
// the tracks are the true ones.
struct TrackScene {
  Eigen::Matrix3d k;
  std::vector<Eigen::Isometry3d> cam_from_world;  ///< True.
  std::vector<Track> tracks;
  int observations = 0;
};

TrackScene MakeTrackScene(unsigned seed) {
  TrackScene scene;
  scene.k << 500, 0, 320, 0, 500, 240, 0, 0, 1;
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> x(-3.0, 3.0), y(-1.5, 1.5), z(3.0, 6.0);
  std::normal_distribution<double> noise(0.0, 0.3);
  for (int i = 0; i < 20; ++i) {
    Eigen::Isometry3d world_from_cam = Eigen::Isometry3d::Identity();
    world_from_cam.translation() = Eigen::Vector3d(-1.0 + 2.0 * i / 19.0, 0.05 * (i % 3), 0.0);
    world_from_cam.linear() = Eigen::AngleAxisd(0.02 * i, Eigen::Vector3d::UnitY()).matrix();
    scene.cam_from_world.push_back(world_from_cam.inverse());
  }
  for (int p = 0; p < 1500; ++p) {
    const Eigen::Vector3d point(x(rng), y(rng), z(rng));
    Track track;
    for (int i = 0; i < 20; ++i) {
      const Eigen::Vector3d in_cam = scene.cam_from_world[static_cast<size_t>(i)] * point;
      const Eigen::Vector2d pixel = (scene.k * in_cam).hnormalized();
      if (pixel.x() < 0 || pixel.y() < 0 || pixel.x() >= 640 || pixel.y() >= 480) continue;
      track.push_back({i, pixel + Eigen::Vector2d(noise(rng), noise(rng))});
    }
    if (track.size() >= 2) {
      scene.observations += static_cast<int>(track.size());
      scene.tracks.push_back(std::move(track));
    }
  }
  return scene;
}

// The true poses with a scale that grows 1.5 % per keyframe after the second (a walk's scale
// drift) and a little rotation noise.
std::vector<Eigen::Isometry3d> ScaleDrifted(const std::vector<Eigen::Isometry3d>& truth) {
  std::vector<Eigen::Isometry3d> out = truth;
  const Eigen::Vector3d c0 = truth[0].inverse().translation();
  for (size_t i = 2; i < truth.size(); ++i) {
    Eigen::Isometry3d world_from_cam = truth[i].inverse();
    const double scale = 1.0 + 0.015 * static_cast<double>(i - 1);
    world_from_cam.translation() = c0 + scale * (world_from_cam.translation() - c0);
    world_from_cam.linear() =
        world_from_cam.linear() *
        Eigen::AngleAxisd(0.002 * static_cast<double>(i % 4), Eigen::Vector3d::UnitX()).matrix();
    out[i] = world_from_cam.inverse();
  }
  return out;
}

double MaxCentreErrorM(const std::vector<Eigen::Isometry3d>& a,
                       const std::vector<Eigen::Isometry3d>& b) {
  double worst = 0.0;
  for (size_t i = 0; i < a.size(); ++i) {
    worst = std::max(worst, (a[i].inverse().translation() - b[i].inverse().translation()).norm());
  }
  return worst;
}

TEST(RefinePosesWithTracks, TakesTheScaleDriftOutOfTheWalksPoses) {
  const TrackScene scene = MakeTrackScene(1);
  const std::vector<Eigen::Isometry3d> start = ScaleDrifted(scene.cam_from_world);
  ASSERT_GT(MaxCentreErrorM(start, scene.cam_from_world), 0.2);  // 27 % at the far end of 2 m.
  const TrackRefineResult r =
      RefinePosesWithTracks(scene.k, scene.tracks, start, TrackRefineOptions{});
  ASSERT_TRUE(r.summary.ran) << r.summary.bundle.message;
  // Measured: 1489 of 1497 tracks (the others seen under less than 1.5 deg), 22 389 of
  // 22 405 observations (those the drift put beyond 4 px come back after the first
  // adjustment), 2.8 mm at most over the 2 m line: the noise's, not the drift's 27 cm.
  EXPECT_GE(r.summary.points, static_cast<int>(0.99 * static_cast<double>(scene.tracks.size())));
  EXPECT_GE(r.summary.observations, static_cast<int>(0.995 * scene.observations));
  EXPECT_LT(r.summary.bundle.final_rms_px, 0.35);
  EXPECT_LT(MaxCentreErrorM(r.cam_from_world, scene.cam_from_world), 0.005);
}

TEST(RefinePosesWithTracks, AConflictingMatchInATrackIsLeftOutAndKeptPointsFollow) {
  TrackScene scene = MakeTrackScene(2);
  // Every tenth track also sees its first keyframe at a keypoint 25 px away (two keypoints of
  // one keyframe joined by wrong matches): the nearest stays, the other goes.
  for (size_t t = 0; t < scene.tracks.size(); t += 10) {
    TrackObservation wrong = scene.tracks[t].front();
    wrong.pixel += Eigen::Vector2d(25.0, -5.0);
    scene.tracks[t].push_back(wrong);
  }
  // One point kept as the walk has it (true position, its two first observations).
  LocalBundleProblem kept;
  const Eigen::Vector3d point_in_world(0.5, 0.2, 4.0);
  kept.points_in_world.push_back(point_in_world + Eigen::Vector3d(0.0, 0.0, 0.3));
  for (int i = 0; i < 2; ++i) {
    kept.observations.push_back(
        {i, 0,
         (scene.k * (scene.cam_from_world[static_cast<size_t>(i)] * point_in_world))
             .hnormalized()});
  }
  const TrackRefineResult r = RefinePosesWithTracks(
      scene.k, scene.tracks, ScaleDrifted(scene.cam_from_world), TrackRefineOptions{}, &kept);
  ASSERT_TRUE(r.summary.ran);
  // The wrong observations are not among them: no more than the true ones.
  EXPECT_LE(r.summary.observations, scene.observations);
  EXPECT_GE(r.summary.observations, static_cast<int>(0.995 * scene.observations));
  EXPECT_LT(MaxCentreErrorM(r.cam_from_world, scene.cam_from_world), 0.005);
  ASSERT_EQ(r.kept_points_in_world.size(), 1u);
  EXPECT_LT((r.kept_points_in_world[0] - point_in_world).norm(), 0.01);
}

TEST(RefinePosesWithTracks, TooFewKeyframesLeaveThePosesAsTheyAre) {
  const TrackScene scene = MakeTrackScene(3);
  const std::vector<Eigen::Isometry3d> two(scene.cam_from_world.begin(),
                                           scene.cam_from_world.begin() + 2);
  const TrackRefineResult r = RefinePosesWithTracks(scene.k, {}, two, TrackRefineOptions{});
  EXPECT_FALSE(r.summary.ran);
  EXPECT_EQ(MaxCentreErrorM(r.cam_from_world, two), 0.0);
}

TEST(TrackRefineOptions, CheckNamesTheField) {
  TrackRefineOptions o;
  EXPECT_EQ(o.Check(), "");
  o.max_axis_angle_deg = 0;
  EXPECT_NE(o.Check().find("max_axis_angle_deg"), std::string::npos);
  o = TrackRefineOptions{};
  o.min_pair_inliers = 3;
  EXPECT_NE(o.Check().find("min_pair_inliers"), std::string::npos);
}

}  // namespace
}  // namespace mm
