#include "dataset/tum.h"

#include <algorithm>
#include <cmath>
#include <locale>
#include <numbers>
#include <sstream>

#include "base/text_file.h"

namespace mm {
namespace {

std::string Where(const std::string& source, int line) {
  return source + ":" + std::to_string(line) + ": ";
}

std::string ReadFileOrThrow(const std::filesystem::path& file) {
  std::string error;
  std::optional<std::string> text = ReadTextFile(file, kMaxDataFileBytes, &error);
  if (!text) throw DatasetError(error);
  return std::move(*text);
}

bool IsBlankOrComment(const std::string& line) {
  const auto first = line.find_first_not_of(" \t\r");
  return first == std::string::npos || line[first] == '#';
}

// Calls parse(fields, line_no, where) for each data line (blank lines and '#' comments
// skipped); `where` is "source:line: " for error messages.
template <typename Parse>
void ForEachDataLine(const std::string& text, const std::string& source, Parse parse) {
  std::istringstream in(text);
  std::string line;
  int line_no = 0;
  while (std::getline(in, line)) {
    ++line_no;
    if (IsBlankOrComment(line)) continue;
    std::istringstream fields(line);
    fields.imbue(std::locale::classic());
    parse(fields, line_no, Where(source, line_no));
  }
}

}  // namespace

std::vector<TumFrame> ParseTumList(const std::string& text, const std::filesystem::path& folder,
                                   const std::string& source_name) {
  std::vector<TumFrame> frames;
  ForEachDataLine(
      text, source_name, [&](std::istringstream& fields, int line_no, const std::string& where) {
        TumFrame frame;
        std::string path;
        if (!(fields >> frame.timestamp_s >> path)) {
          throw DatasetError(where + "expected 'timestamp path'");
        }
        frame.path =
            std::filesystem::path(path).is_absolute() ? std::filesystem::path(path) : folder / path;
        frame.line = line_no;
        frames.push_back(std::move(frame));
      });
  if (frames.empty()) throw DatasetError(source_name + ": no frames listed");
  return frames;
}

std::vector<TumFrame> ReadTumList(const std::filesystem::path& list_file) {
  return ParseTumList(ReadFileOrThrow(list_file), list_file.parent_path(), list_file.string());
}

std::string CheckTimeOrder(const std::vector<TumFrame>& frames, double max_gap_s,
                           const std::string& list_name) {
  for (size_t i = 1; i < frames.size(); ++i) {
    const double gap_s = frames[i].timestamp_s - frames[i - 1].timestamp_s;
    const std::string where = Where(list_name, frames[i].line) + "timestamp ";
    if (!(gap_s >= 0.0)) {
      return where + std::to_string(frames[i].timestamp_s) + " is before the previous frame's " +
             std::to_string(frames[i - 1].timestamp_s) + " (the list must be in time order)";
    }
    if (gap_s > max_gap_s) {
      return where + std::to_string(frames[i].timestamp_s) + " is " + std::to_string(gap_s) +
             " s after the previous frame (at most " + std::to_string(max_gap_s) + " s)";
    }
  }
  return {};
}

Trajectory Trajectory::Parse(const std::string& text, const std::string& source_name) {
  std::vector<TimedPose> poses;
  ForEachDataLine(text, source_name,
                  [&](std::istringstream& fields, int, const std::string& where) {
                    double t = 0;
                    double tx = 0, ty = 0, tz = 0, qx = 0, qy = 0, qz = 0, qw = 0;
                    if (!(fields >> t >> tx >> ty >> tz >> qx >> qy >> qz >> qw)) {
                      throw DatasetError(where + "expected 'timestamp tx ty tz qx qy qz qw'");
                    }
                    Eigen::Quaterniond q(qw, qx, qy, qz);
                    if (!(q.norm() > 0.5))
                      throw DatasetError(where + "quaternion is not unit length");
                    TimedPose pose;
                    pose.timestamp_s = t;
                    pose.world_from_cam = Eigen::Isometry3d::Identity();
                    pose.world_from_cam.linear() = q.normalized().toRotationMatrix();
                    pose.world_from_cam.translation() = Eigen::Vector3d(tx, ty, tz);
                    poses.push_back(pose);
                  });
  if (poses.empty()) throw DatasetError(source_name + ": no poses");
  return Trajectory(std::move(poses));
}

Trajectory Trajectory::Read(const std::filesystem::path& groundtruth_file) {
  return Parse(ReadFileOrThrow(groundtruth_file), groundtruth_file.string());
}

Trajectory::Trajectory(std::vector<TimedPose> poses) : poses_(std::move(poses)) {
  std::sort(poses_.begin(), poses_.end(),
            [](const TimedPose& a, const TimedPose& b) { return a.timestamp_s < b.timestamp_s; });
}

std::optional<Eigen::Isometry3d> Trajectory::WorldFromCamAt(double timestamp_s,
                                                            double max_extrapolation_s) const {
  if (poses_.empty()) return std::nullopt;
  auto after = std::lower_bound(poses_.begin(), poses_.end(), timestamp_s,
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

int NearestFrame(const std::vector<TumFrame>& frames, double timestamp_s, double max_dt_s) {
  int best = -1;
  double best_dt = max_dt_s;
  for (size_t i = 0; i < frames.size(); ++i) {
    const double dt = std::abs(frames[i].timestamp_s - timestamp_s);
    if (dt <= best_dt) {
      best_dt = dt;
      best = static_cast<int>(i);
    }
  }
  return best;
}

TumSequence ReadTumSequence(const std::filesystem::path& folder,
                            const std::filesystem::path& list) {
  std::filesystem::path list_file = list.empty() ? folder / "rgb.txt" : list;
  if (list_file.is_relative() && !std::filesystem::exists(list_file)) list_file = folder / list;
  TumSequence sequence;
  sequence.frames = ReadTumList(list_file);
  sequence.trajectory = Trajectory::Read(folder / "groundtruth.txt");
  if (std::filesystem::exists(folder / "depth.txt")) {
    sequence.depth_frames = ReadTumList(folder / "depth.txt");
  }
  return sequence;
}

}  // namespace mm
