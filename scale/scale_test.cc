// The scale sources on synthetic data with known answers: the odometry line protocol and its
// interpolation, the floor plane among a room's points (walls and a table top included), and
// the choice between the sources.
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <iostream>
#include <opencv2/imgproc.hpp>
#include <random>
#include <vector>

#include "scale/floor_plane.h"
#include "scale/metric_scale.h"
#include "scale/odometry.h"
#include "scale/room_planes.h"
#include "scale/vertical_vanishing_point.h"

namespace mm {
namespace {

TEST(OdometryLine, ParsesPositionAndNormalisesTheQuaternion) {
  std::string error;
  const auto p = ParseOdometryLine("12.5 1 -2.25 +0.5", &error);
  ASSERT_TRUE(p) << error;
  EXPECT_DOUBLE_EQ(p->time_s, 12.5);
  EXPECT_EQ(p->position_m, Eigen::Vector3d(1, -2.25, 0.5));
  EXPECT_FALSE(p->orientation);
  const auto q = ParseOdometryLine(" 1 0 0 0  0 0 0 2\r\n", &error);
  ASSERT_TRUE(q && q->orientation) << error;
  EXPECT_NEAR(q->orientation->w(), 1.0, 1e-12);
}

TEST(OdometryLine, NamesTheFieldThatIsWrong) {
  std::string error;
  EXPECT_FALSE(ParseOdometryLine("1 2 3", &error));
  EXPECT_NE(error.find("Z is missing"), std::string::npos) << error;
  EXPECT_FALSE(ParseOdometryLine("1 2 nan 4", &error));
  EXPECT_NE(error.find("Y is not a finite number"), std::string::npos) << error;
  EXPECT_FALSE(ParseOdometryLine("1e400 2 3 4", &error));
  EXPECT_NE(error.find("T is not"), std::string::npos) << error;
  EXPECT_FALSE(ParseOdometryLine("1 2 3 4x", &error));
  EXPECT_NE(error.find("Z is not"), std::string::npos) << error;
  EXPECT_FALSE(ParseOdometryLine("1 2 3 4 0 0", &error));
  EXPECT_NE(error.find("quaternion needs all"), std::string::npos) << error;
  EXPECT_FALSE(ParseOdometryLine("1 2 3 4 0 0 0 0", &error));
  EXPECT_NE(error.find("zero norm"), std::string::npos) << error;
  EXPECT_FALSE(ParseOdometryLine("1 2 3 4 0 0 0 1 9", &error));
  EXPECT_NE(error.find("more than 8"), std::string::npos) << error;
  EXPECT_FALSE(ParseOdometryLine("", &error));
  EXPECT_NE(error.find("T is missing"), std::string::npos) << error;
}

OdometrySample Sample(double time_s, double x_m) {
  OdometrySample s;
  s.time_s = time_s;
  s.position_m = Eigen::Vector3d(x_m, 0, 0);
  return s;
}

TEST(OdometryTrack, InterpolatesBetweenNeighboursInAnyArrivalOrder) {
  OdometryTrack track;
  // A robot driving at 0.4 m/s along x, samples every 0.1 s arriving out of order.
  for (int i : {0, 2, 1, 4, 3, 5}) track.Add(Sample(10.0 + 0.1 * i, 0.04 * i));
  EXPECT_EQ(track.size(), 6u);
  std::string why;
  const auto at = track.PositionAt(10.25, {}, &why);
  ASSERT_TRUE(at) << why;
  EXPECT_NEAR(at->x(), 0.1, 1e-12);
  // Held within max_age_s past either end, refused beyond.
  ASSERT_TRUE(track.PositionAt(10.9, {.max_age_s = 0.5}, &why));
  EXPECT_FALSE(track.PositionAt(11.1, {.max_age_s = 0.5}, &why));
  EXPECT_NE(why.find("0.600 s from the keyframe"), std::string::npos) << why;
  // A gap in the stream does not bracket.
  track.Add(Sample(20.0, 9.0));
  EXPECT_FALSE(track.PositionAt(15.0, {.max_age_s = 0.5, .max_gap_s = 1.0}, &why));
  EXPECT_NE(why.find("gap of"), std::string::npos) << why;
  // A sample at an existing time replaces it; the capacity drops the oldest.
  OdometryTrack small(3);
  for (int i = 0; i < 5; ++i) small.Add(Sample(1.0 * i, 1.0 * i));
  small.Add(Sample(4.0, 7.0));
  EXPECT_EQ(small.size(), 3u);
  EXPECT_EQ(small.newest().position_m.x(), 7.0);
  EXPECT_FALSE(small.PositionAt(0.0, {.max_age_s = 0.5}, &why));
  EXPECT_FALSE(OdometryTrack().PositionAt(0.0, {}, &why));
  EXPECT_EQ(why, "no odometry received");
}

// A room seen from a camera `height_m` above the floor, pitched down `pitch_deg`: floor points,
// a table top 0.75 m above the floor with more points than the floor, two walls; in units of
// `metres_per_unit`, in the camera's frame, with noise of `noise_m`.
std::vector<Eigen::Vector3d> Room(double height_m, double pitch_deg, double metres_per_unit,
                                  double noise_m, uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  std::normal_distribution<double> noise(0.0, noise_m);
  // World: x right, y up, z forward; camera at (0, height, 0).
  std::vector<Eigen::Vector3d> world;
  for (int i = 0; i < 200; ++i)
    world.emplace_back(1.5 * u(rng), 0.0, 3.0 + 1.5 * u(rng));  // Floor.
  for (int i = 0; i < 300; ++i)
    world.emplace_back(0.4 * u(rng) + 0.3, 0.75, 2.0 + 0.3 * u(rng));                  // Table.
  for (int i = 0; i < 300; ++i) world.emplace_back(-1.6, 1.2 + u(rng), 3.0 + u(rng));  // Walls.
  for (int i = 0; i < 300; ++i) world.emplace_back(u(rng), 1.2 + u(rng), 5.0);
  const double p = pitch_deg * M_PI / 180.0;
  // Camera frame: x right, y down, z forward; pitched down by p about x.
  const Eigen::Matrix3d cam_from_level =
      Eigen::AngleAxisd(p, Eigen::Vector3d::UnitX()).toRotationMatrix();
  std::vector<Eigen::Vector3d> cam;
  for (const Eigen::Vector3d& w : world) {
    const Eigen::Vector3d noisy = w + Eigen::Vector3d(noise(rng), noise(rng), noise(rng));
    const Eigen::Vector3d level(noisy.x(), height_m - noisy.y(), noisy.z());
    cam.push_back(cam_from_level * level / metres_per_unit);
  }
  return cam;
}

double AngleDeg(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  return std::acos(std::clamp(a.normalized().dot(b.normalized()), -1.0, 1.0)) * 180.0 / M_PI;
}

TEST(RoomPlanes, FindsTheFloorBelowATableTopWithMorePoints) {
  const double height = 1.2, pitch = 12.0, mpu = 0.35;
  const std::vector<Eigen::Vector3d> points = Room(height, pitch, mpu, 0.005, 7);
  // The level frame's up is exact for the room; tell the fit the nominal pitch only to 3 deg.
  const RoomPlanes room = FitRoomPlanes(points, UpInCamera(pitch + 3.0));
  ASSERT_TRUE(room.found) << room.why_not;
  std::cout << "[ figures  ] up off by " << AngleDeg(room.up_in_cam, UpInCamera(pitch))
            << " deg, height " << room.floor.distance * mpu << " m\n";
  EXPECT_NEAR(room.floor.distance * mpu, height, 0.005 * height);
  EXPECT_NEAR(room.floor.normal_angle_deg, 3.0, 0.1);
  EXPECT_LT(AngleDeg(room.up_in_cam, UpInCamera(pitch)), 0.1);
  EXPECT_EQ(room.horizontal_planes, 2);  // Floor and table.
  EXPECT_EQ(room.walls, 2);
  EXPECT_GE(room.floor.inliers, 190);
  EXPECT_LE(room.floor.inliers, 200);
  // The pitch says the camera looks down: UpInCamera is the frame's -y tilted towards -z.
  EXPECT_NEAR(UpInCamera(90.0).z(), -1.0, 1e-12);
}

TEST(RoomPlanes, NoHorizontalPlaneBelowTheCameraIsReported) {
  std::vector<Eigen::Vector3d> walls = Room(1.2, 0.0, 1.0, 0.002, 3);
  walls.erase(walls.begin(), walls.begin() + 500);  // Walls only.
  const RoomPlanes room = FitRoomPlanes(walls, UpInCamera(0.0));
  EXPECT_FALSE(room.found);
  EXPECT_NE(room.why_not.find("no floor in view"), std::string::npos) << room.why_not;
  EXPECT_FALSE(
      FitRoomPlanes(std::vector<Eigen::Vector3d>(5, Eigen::Vector3d::Zero()), UpInCamera(0)).found);
}

// A corridor seen by a camera 1.6 m up, pitched down 1.2 deg and rolled 0.7 deg: the floor a
// strip 4-5.5 m ahead (a grazing view), side walls 1 m left and right, the end wall 6 m ahead,
// the ceiling at 2.5 m; noise 0.5 % of each point's depth along its ray (as dense depth errs).
std::vector<Eigen::Vector3d> Corridor(const Eigen::Matrix3d& cam_from_level, bool with_floor,
                                      uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::normal_distribution<double> noise(0.0, 0.005);
  std::vector<Eigen::Vector3d> level;  // x right, y down, z forward; the floor at y = 1.6.
  if (with_floor) {
    for (int i = 0; i < 400; ++i) level.emplace_back(-1 + 2 * u(rng), 1.6, 4.0 + 1.5 * u(rng));
  }
  for (int i = 0; i < 800; ++i) {
    level.emplace_back(i % 2 ? 1.0 : -1.0, -0.9 + 2.5 * u(rng), 1.0 + 5.0 * u(rng));
  }
  for (int i = 0; i < 600; ++i) level.emplace_back(-1 + 2 * u(rng), -0.9 + 2.5 * u(rng), 6.0);
  for (int i = 0; i < 300; ++i) level.emplace_back(-1 + 2 * u(rng), -0.9, 2.0 + 4.0 * u(rng));
  std::vector<Eigen::Vector3d> cam;
  for (const Eigen::Vector3d& x : level) {
    const Eigen::Vector3d c = cam_from_level * x;
    cam.push_back(c * (1.0 + noise(rng)));
  }
  return cam;
}

TEST(RoomPlanes, TheWallsFixTheUpDirectionWhereTheFloorStripCannot) {
  constexpr double kDeg = 3.14159265358979323846 / 180.0;
  const Eigen::Matrix3d cam_from_level = (Eigen::AngleAxisd(-1.2 * kDeg, Eigen::Vector3d::UnitX()) *
                                          Eigen::AngleAxisd(0.7 * kDeg, Eigen::Vector3d::UnitZ()))
                                             .toRotationMatrix();
  const Eigen::Vector3d true_up = cam_from_level * Eigen::Vector3d(0, -1, 0);
  const RoomPlanes room = FitRoomPlanes(Corridor(cam_from_level, true, 5), UpInCamera(0.0));
  ASSERT_TRUE(room.found) << room.why_not;
  EXPECT_EQ(room.walls, 3);
  EXPECT_EQ(room.horizontal_planes, 2);
  // Measured 0.03 deg and 0.08 %; every 0.1 deg of pitch is 0.5 % of the height at 4.5 m.
  std::cout << "[ figures  ] up off by " << AngleDeg(room.up_in_cam, true_up) << " deg, height "
            << room.floor.distance << " m, rms " << room.rms_residual_rel << "\n";
  EXPECT_LT(AngleDeg(room.up_in_cam, true_up), 0.1);
  EXPECT_NEAR(room.floor.distance, 1.6, 0.004 * 1.6);
  EXPECT_GE(room.floor.inliers, 380);
  EXPECT_LT(room.rms_residual_rel, 0.006);
}

// A box top 0.6 m above a floor that is out of view, with the walls reaching down to the floor:
// the lowest horizontal plane has points below it, so it is no floor.
TEST(RoomPlanes, ABoxTopWithTheWallsReachingBelowItIsNoFloor) {
  std::vector<Eigen::Vector3d> points = Corridor(Eigen::Matrix3d::Identity(), false, 9);
  std::mt19937 rng(2);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  for (int i = 0; i < 300; ++i) points.emplace_back(-0.3 + 0.6 * u(rng), 1.0, 3.0 + 0.5 * u(rng));
  const RoomPlanes room = FitRoomPlanes(points, UpInCamera(0.0));
  EXPECT_FALSE(room.found);
  EXPECT_NE(room.why_not.find("below the lowest horizontal plane"), std::string::npos)
      << room.why_not;
}

TEST(MetricScale, OdometryGivesTheBaselineInMetres) {
  ScaleOptions options;
  options.source = ScaleSource::kOdometry;
  ScaleInputs in;
  in.odometry_a_m = Eigen::Vector3d(1, 2, 0);
  in.odometry_b_m = Eigen::Vector3d(1.3, 2.4, 0);
  in.baseline_units = 2.0;
  const ScaleEstimate s = EstimateScale(in, options);
  ASSERT_TRUE(s.scaled()) << s.why_not;
  EXPECT_EQ(s.source, ScaleSource::kOdometry);
  EXPECT_NEAR(s.metres_per_unit, 0.25, 1e-12);
  EXPECT_NEAR(s.uncertainty_rel, std::sqrt(2.0) * 0.01 / 0.5, 1e-12);

  in.odometry_b_m = Eigen::Vector3d(1.02, 2, 0);
  const ScaleEstimate short_baseline = EstimateScale(in, options);
  EXPECT_FALSE(short_baseline.scaled());
  EXPECT_NE(short_baseline.why_not.find("min_baseline_m"), std::string::npos);
  EXPECT_EQ(short_baseline.metres_per_unit, 1.0);
}

TEST(MetricScale, AutoFallsBackToTheFloorAndRefusesWhenTheSourcesDisagree) {
  const double height = 1.1, mpu = 0.3;
  const std::vector<Eigen::Vector3d> points = Room(height, 5.0, mpu, 0.004, 11);
  ScaleOptions options;
  options.source = ScaleSource::kAuto;
  options.camera_height_m = height;
  options.camera_pitch_deg = 5.0;
  ScaleInputs in;
  in.points_in_a = points;
  in.baseline_units = 1.0;
  in.odometry_why_not = "the nearest odometry is 3.000 s from the keyframe";
  const ScaleEstimate floor = EstimateScale(in, options);
  ASSERT_TRUE(floor.scaled()) << floor.why_not;
  EXPECT_EQ(floor.source, ScaleSource::kFloor);
  EXPECT_NEAR(floor.metres_per_unit, mpu, 0.01 * mpu);
  EXPECT_NE(floor.why_not.find("odometry: the nearest odometry is 3.000 s"), std::string::npos);

  // Odometry that agrees wins; one 30 % off leaves the pair unscaled, saying why.
  in.odometry_a_m = Eigen::Vector3d::Zero();
  in.odometry_b_m = Eigen::Vector3d(0.0, 0.0, 1.01 * mpu);
  const ScaleEstimate both = EstimateScale(in, options);
  EXPECT_EQ(both.source, ScaleSource::kOdometry);
  EXPECT_NEAR(both.floor_metres_per_unit, mpu, 0.01 * mpu);
  in.odometry_b_m = Eigen::Vector3d(0.0, 0.0, 1.3 * mpu);
  const ScaleEstimate disagree = EstimateScale(in, options);
  EXPECT_FALSE(disagree.scaled());
  EXPECT_NE(disagree.why_not.find("disagree by 2"), std::string::npos) << disagree.why_not;

  options.source = ScaleSource::kNone;
  EXPECT_FALSE(EstimateScale(in, options).scaled());
  options.source = ScaleSource::kFloor;
  options.camera_height_m = 0.0;
  EXPECT_NE(options.Check().find("camera_height_m"), std::string::npos);
  EXPECT_EQ(ParseScaleSource("auto"), ScaleSource::kAuto);
  EXPECT_FALSE(ParseScaleSource("metres"));
}

// A camera pitched down by `pitch_deg` and rolled by `roll_deg` in a corridor of vertical edges
// (door frames, corners: 3 m high, 1-8 m ahead, 1.2 m either side) and a few horizontal ones,
// drawn anti-aliased on a noisy grey image (seeded); returns the true up in the camera frame.
Eigen::Vector3d DrawCorridorEdges(double pitch_deg, double roll_deg, const Eigen::Matrix3d& K,
                                  cv::Mat* gray) {
  constexpr double kDeg = 3.14159265358979323846 / 180.0;
  // World: x right, y down, z forward (a level camera's frame); the camera 1.6 m up.
  const Eigen::Matrix3d cam_from_world =
      (Eigen::AngleAxisd(roll_deg * kDeg, Eigen::Vector3d::UnitZ()) *
       Eigen::AngleAxisd(-pitch_deg * kDeg, Eigen::Vector3d::UnitX()))
          .toRotationMatrix();
  *gray = cv::Mat(480, 640, CV_8UC1);
  cv::RNG rng(7);
  rng.fill(*gray, cv::RNG::NORMAL, 128, 6);
  const auto project = [&](const Eigen::Vector3d& world) {
    const Eigen::Vector3d p = K * (cam_from_world * world);
    return cv::Point2d(p.x() / p.z(), p.y() / p.z());
  };
  const auto draw = [&](const Eigen::Vector3d& a, const Eigen::Vector3d& b, int shade) {
    cv::line(*gray, project(a), project(b), cv::Scalar(shade), 2, cv::LINE_AA);
  };
  for (double z : {1.5, 2.3, 3.1, 4.4, 6.0, 8.0}) {
    for (double x : {-1.2, 1.2}) {
      // From the floor (y = 1.6) to the ceiling (y = -1.4), clipped to in front of the camera.
      draw({x, 1.6, z}, {x, -1.4, z}, z < 4 ? 30 : 230);
    }
  }
  // Lines along the corridor (wall-floor, wall-ceiling, door tops): not vertical.
  for (double x : {-1.2, 1.2}) {
    for (double y : {1.6, -1.4, -0.5}) draw({x, y, 1.5}, {x, y, 8.0}, y < 0 ? 200 : 60);
  }
  return cam_from_world * Eigen::Vector3d(0, -1, 0);
}

TEST(VerticalLines, FindsUpFromTheConvergenceOfVerticalEdges) {
  Eigen::Matrix3d K;
  K << 525, 0, 319.5, 0, 525, 239.5, 0, 0, 1;
  for (const auto& [pitch, roll] : {std::pair{0.0, 0.0}, {1.5, -1.0}, {-2.0, 2.5}, {8.0, 0.5}}) {
    cv::Mat gray;
    const Eigen::Vector3d truth = DrawCorridorEdges(pitch, roll, K, &gray);
    // Expected: a level camera; the true up is up to 8 deg away from it.
    const VerticalVanishingPoint vp = EstimateVerticalVanishingPoint(gray, K, UpInCamera(0.0));
    ASSERT_TRUE(vp.found) << "pitch " << pitch << ": " << vp.why_not;
    const double error_deg =
        std::acos(std::clamp(vp.up_in_cam.dot(truth), -1.0, 1.0)) * 180.0 / 3.14159265358979;
    // Measured 0.01-0.05 deg on these drawings.
    EXPECT_LT(error_deg, 0.15) << "pitch " << pitch << ", roll " << roll << ": " << vp.inliers
                               << " inliers of " << vp.segments;
    EXPECT_GE(vp.inliers, 8);
  }
}

TEST(VerticalLines, NoVerticalEdgesIsReported) {
  cv::Mat gray(480, 640, CV_8UC1, cv::Scalar(128));
  for (int y = 60; y < 480; y += 60) cv::line(gray, {20, y}, {620, y + 10}, cv::Scalar(20), 2);
  Eigen::Matrix3d K;
  K << 525, 0, 319.5, 0, 525, 239.5, 0, 0, 1;
  const VerticalVanishingPoint vp = EstimateVerticalVanishingPoint(gray, K, UpInCamera(0.0));
  EXPECT_FALSE(vp.found);
  EXPECT_NE(vp.why_not.find("vertical"), std::string::npos) << vp.why_not;
}

// A strip of floor 1.2 m deep, 4-5.2 m ahead of a camera 1.6 m up pitched by 1.5 deg, with
// 2 cm of noise: with the normal given, the distance comes out to a fraction of the noise.
TEST(FloorPlane, AlongAKnownNormalAShallowStripGivesTheDistance) {
  constexpr double kDeg = 3.14159265358979323846 / 180.0;
  const Eigen::Matrix3d cam_from_world =
      Eigen::AngleAxisd(-1.5 * kDeg, Eigen::Vector3d::UnitX()).toRotationMatrix();
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> x(-1.0, 1.0), z(4.0, 5.2), wall(-1.4, 1.6);
  std::normal_distribution<double> noise(0.0, 0.02);
  std::vector<Eigen::Vector3d> points;
  for (int i = 0; i < 400; ++i) {
    points.push_back(cam_from_world * Eigen::Vector3d(x(rng), 1.6 + noise(rng), z(rng)));
  }
  for (int i = 0; i < 600; ++i) {  // The side walls.
    points.push_back(cam_from_world *
                     Eigen::Vector3d(i % 2 ? 1.0 : -1.0, wall(rng), 1.0 + 0.01 * i));
  }
  const Eigen::Vector3d up = cam_from_world * Eigen::Vector3d(0, -1, 0);
  const FloorPlane floor = FitFloorPlaneAlong(points, up);
  ASSERT_TRUE(floor.found) << floor.why_not;
  EXPECT_NEAR(floor.distance, 1.6, 0.005);
  EXPECT_NEAR(floor.normal.dot(up), 1.0, 1e-12);
  EXPECT_GE(floor.inliers, 340);  // The band (2 % of 1.6 m) is 1.6 sigma: 89 % of 400.
}

}  // namespace
}  // namespace mm
