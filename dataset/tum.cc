#include "dataset/tum.h"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <numbers>
#include <sstream>

namespace mm {
namespace {

std::string Where(const std::filesystem::path& file, int line) {
  return file.string() + ":" + std::to_string(line) + ": ";
}

std::ifstream OpenOrThrow(const std::filesystem::path& file) {
  std::ifstream in(file);
  if (!in) throw DatasetError(file.string() + ": cannot open for reading");
  return in;
}

bool IsBlankOrComment(const std::string& line) {
  const auto first = line.find_first_not_of(" \t\r");
  return first == std::string::npos || line[first] == '#';
}

// Calls parse(fields, where) for each data line (blank lines and '#' comments skipped); `where`
// is "file:line: " for error messages.
template <typename Parse>
void ForEachDataLine(const std::filesystem::path& file, Parse parse) {
  std::ifstream in = OpenOrThrow(file);
  std::string line;
  int line_no = 0;
  while (std::getline(in, line)) {
    ++line_no;
    if (IsBlankOrComment(line)) continue;
    std::istringstream fields(line);
    parse(fields, Where(file, line_no));
  }
}

}  // namespace

std::vector<TumFrame> ReadTumList(const std::filesystem::path& list_file) {
  const std::filesystem::path folder = list_file.parent_path();
  std::vector<TumFrame> frames;
  ForEachDataLine(list_file, [&](std::istringstream& fields, const std::string& where) {
    TumFrame frame;
    std::string path;
    if (!(fields >> frame.timestamp_s >> path)) {
      throw DatasetError(where + "expected 'timestamp path'");
    }
    frame.path = std::filesystem::path(path).is_absolute() ? std::filesystem::path(path)
                                                            : folder / path;
    frames.push_back(std::move(frame));
  });
  if (frames.empty()) throw DatasetError(list_file.string() + ": no frames listed");
  return frames;
}

Trajectory Trajectory::Read(const std::filesystem::path& groundtruth_file) {
  std::vector<TimedPose> poses;
  ForEachDataLine(groundtruth_file, [&](std::istringstream& fields, const std::string& where) {
    double t = 0;
    double tx = 0, ty = 0, tz = 0, qx = 0, qy = 0, qz = 0, qw = 0;
    if (!(fields >> t >> tx >> ty >> tz >> qx >> qy >> qz >> qw)) {
      throw DatasetError(where + "expected 'timestamp tx ty tz qx qy qz qw'");
    }
    Eigen::Quaterniond q(qw, qx, qy, qz);
    if (!(q.norm() > 0.5)) throw DatasetError(where + "quaternion is not unit length");
    TimedPose pose;
    pose.timestamp_s = t;
    pose.world_from_cam = Eigen::Isometry3d::Identity();
    pose.world_from_cam.linear() = q.normalized().toRotationMatrix();
    pose.world_from_cam.translation() = Eigen::Vector3d(tx, ty, tz);
    poses.push_back(pose);
  });
  if (poses.empty()) throw DatasetError(groundtruth_file.string() + ": no poses");
  return Trajectory(std::move(poses));
}

Trajectory::Trajectory(std::vector<TimedPose> poses) : poses_(std::move(poses)) {
  std::sort(poses_.begin(), poses_.end(),
            [](const TimedPose& a, const TimedPose& b) { return a.timestamp_s < b.timestamp_s; });
}

std::optional<Eigen::Isometry3d> Trajectory::WorldFromCamAt(double timestamp_s,
                                                            double max_extrapolation_s) const {
  if (poses_.empty()) return std::nullopt;
  auto after = std::lower_bound(
      poses_.begin(), poses_.end(), timestamp_s,
      [](const TimedPose& p, double t) { return p.timestamp_s < t; });
  if (after == poses_.begin() || after == poses_.end()) {
    const TimedPose& nearest = after == poses_.begin() ? poses_.front() : poses_.back();
    if (std::abs(nearest.timestamp_s - timestamp_s) > max_extrapolation_s) return std::nullopt;
    return nearest.world_from_cam;
  }
  const TimedPose& b = *after;
  const TimedPose& a = *(after - 1);
  const double span = b.timestamp_s - a.timestamp_s;
  const double s = span > 0 ? (timestamp_s - a.timestamp_s) / span : 0.0;
  const Eigen::Quaterniond qa(a.world_from_cam.linear());
  const Eigen::Quaterniond qb(b.world_from_cam.linear());
  Eigen::Isometry3d out = Eigen::Isometry3d::Identity();
  out.linear() = qa.slerp(s, qb).toRotationMatrix();
  out.translation() =
      (1.0 - s) * a.world_from_cam.translation() + s * b.world_from_cam.translation();
  return out;
}

Eigen::Isometry3d CamBFromCamA(const Eigen::Isometry3d& world_from_a,
                               const Eigen::Isometry3d& world_from_b) {
  return world_from_b.inverse() * world_from_a;
}

double RotationErrorDeg(const Eigen::Matrix3d& r_est, const Eigen::Matrix3d& r_gt) {
  const Eigen::AngleAxisd diff(r_est.transpose() * r_gt);
  return std::abs(diff.angle()) * 180.0 / std::numbers::pi;
}

double DirectionErrorDeg(const Eigen::Vector3d& t_est, const Eigen::Vector3d& t_gt) {
  const double n = t_est.norm() * t_gt.norm();
  if (n <= 0) return 0.0;
  const double c = std::clamp(t_est.dot(t_gt) / n, -1.0, 1.0);
  return std::acos(c) * 180.0 / std::numbers::pi;
}

}  // namespace mm
