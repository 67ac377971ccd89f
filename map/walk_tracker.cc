#include "map/walk_tracker.h"

#include <algorithm>
#include <cmath>
#include <opencv2/video/tracking.hpp>
#include <utility>

#include "base/stats.h"
#include "recon/view_pose.h"

namespace mm {

std::string WalkTrackerOptions::Check() const {
  if (std::string p = walk.Check(); !p.empty()) return "walk." + p;
  if (std::string p = gate.Check(); !p.empty()) return "gate." + p;
  if (!(min_tracked_share >= 0 && min_tracked_share <= 1)) {
    return "min_tracked_share: must be in [0, 1]";
  }
  if (min_tracked_points < 6) return "min_tracked_points: must be >= 6";
  if (max_tracked_points < min_tracked_points) {
    return "max_tracked_points: must be >= min_tracked_points";
  }
  if (!(track_reprojection_px > 0)) return "track_reprojection_px: must be > 0";
  if (track_ransac_iterations < 1) return "track_ransac_iterations: must be >= 1";
  if (klt_window_px < 3) return "klt_window_px: must be >= 3";
  if (klt_levels < 0) return "klt_levels: must be >= 0";
  if (lost_retry_frames < 1) return "lost_retry_frames: must be >= 1";
  return {};
}

WalkTracker::WalkTracker(const Eigen::Matrix3d& K, const WalkTrackerOptions& options)
    : K_(K), options_(options), map_(K, options.walk), gate_(K, options.gate) {}

void WalkTracker::Seed(const cv::Mat& gray) {
  previous_ = gray.clone();
  track_pixels_.clear();
  track_points_.clear();
  seeded_points_ = 0;
  segment_ = -1;
  if (map_.lost()) return;
  const int newest = map_.newest_keyframe();
  if (newest < 0 || newest != static_cast<int>(map_.keyframes().size()) - 1) return;
  const WalkKeyframe& k = map_.keyframes()[static_cast<size_t>(newest)];
  segment_ = k.segment;
  cam_from_segment_ = k.cam_from_segment;
  // At most one map point per cell of a grid, so that the tracks cover the image.
  const int cells = 16;
  const double cell_w = gray.cols / static_cast<double>(cells);
  const double cell_h = gray.rows / static_cast<double>(cells);
  const int per_cell = std::max(1, options_.max_tracked_points / (cells * cells) + 1);
  std::vector<int> in_cell(static_cast<size_t>(cells * cells), 0);
  for (size_t i = 0; i < k.point_of_keypoint.size(); ++i) {
    const int id = k.point_of_keypoint[i];
    if (id < 0 || !map_.points()[static_cast<size_t>(id)].valid) continue;
    const Eigen::Vector2f& p = k.keypoint_pixels[i];
    const int cx = std::clamp(static_cast<int>(p.x() / cell_w), 0, cells - 1);
    const int cy = std::clamp(static_cast<int>(p.y() / cell_h), 0, cells - 1);
    int& n = in_cell[static_cast<size_t>(cy) * cells + static_cast<size_t>(cx)];
    if (n >= per_cell) continue;
    ++n;
    track_pixels_.emplace_back(p.x(), p.y());
    track_points_.push_back(id);
    if (static_cast<int>(track_points_.size()) >= options_.max_tracked_points) break;
  }
  seeded_points_ = static_cast<int>(track_points_.size());
  keyframe_centre_ = k.cam_from_segment.inverse().translation();
  if (seeded_points_ < options_.min_tracked_points) segment_ = -1;
}

double WalkTracker::MedianTriangulationAngleDeg(const Eigen::Isometry3d& cam_from_segment) const {
  const Eigen::Vector3d centre = cam_from_segment.inverse().translation();
  std::vector<double> angles;
  angles.reserve(track_points_.size());
  for (int id : track_points_) {
    const Eigen::Vector3d& x = map_.points()[static_cast<size_t>(id)].position_in_segment;
    const Eigen::Vector3d a = x - keyframe_centre_, b = x - centre;
    const double norms = a.norm() * b.norm();
    if (norms > 0) angles.push_back(std::acos(std::clamp(a.dot(b) / norms, -1.0, 1.0)));
  }
  if (angles.empty()) return 0.0;
  return MedianOf(std::move(angles)) * 180.0 / M_PI;
}

void WalkTracker::Track(const cv::Mat& gray, WalkFrameStep* step) {
  if (segment_ < 0 || track_pixels_.size() < 6) {
    previous_ = gray.clone();
    return;
  }
  std::vector<cv::Point2f> next;
  std::vector<unsigned char> status;
  std::vector<float> error;
  cv::calcOpticalFlowPyrLK(previous_, gray, track_pixels_, next, status, error,
                           cv::Size(options_.klt_window_px, options_.klt_window_px),
                           options_.klt_levels);
  previous_ = gray.clone();
  std::vector<Eigen::Vector3d> object;
  std::vector<Eigen::Vector2d> image;
  std::vector<size_t> track;
  for (size_t i = 0; i < next.size(); ++i) {
    if (!status[i] || next[i].x < 0 || next[i].y < 0 || next[i].x > gray.cols - 1 ||
        next[i].y > gray.rows - 1) {
      continue;
    }
    const WalkPoint& p = map_.points()[static_cast<size_t>(track_points_[i])];
    if (!p.valid || p.segment != segment_) continue;
    object.push_back(p.position_in_segment);
    image.emplace_back(next[i].x, next[i].y);
    track.push_back(i);
  }
  std::vector<cv::Point2f> kept_pixels;
  std::vector<int> kept_points;
  if (static_cast<int>(object.size()) >= options_.min_tracked_points) {
    const PnpRansacPose pose =
        SolvePnpRansacRefined(object, image, K_,
                              {.threshold_px = options_.track_reprojection_px,
                               .iterations = options_.track_ransac_iterations,
                               .confidence = 0.999,
                               .sqpnp = true});
    if (pose.found && static_cast<int>(pose.inliers.size()) >= options_.min_tracked_points) {
      cam_from_segment_.linear() = pose.rotation;
      cam_from_segment_.translation() = pose.translation;
      step->tracked = true;
      for (int i : pose.inliers) {
        const size_t t = track[static_cast<size_t>(i)];
        kept_pixels.push_back(next[t]);
        kept_points.push_back(track_points_[t]);
      }
    }
  }
  track_pixels_ = std::move(kept_pixels);
  track_points_ = std::move(kept_points);
  step->tracked_points = static_cast<int>(track_points_.size());
  if (step->tracked) {
    ++tracked_frames_;
    step->segment = segment_;
    step->cam_from_segment = cam_from_segment_;
  } else {
    segment_ = -1;  // Lost: the next keyframe registers without a prior.
  }
}

WalkFrameStep WalkTracker::AddFrame(const cv::Mat& gray, double timestamp_s) {
  WalkFrameStep step;
  if (!started_) {
    started_ = true;
    step.keyframe_reason = "first";
  } else if (segment_ >= 0) {
    // Tracking: the pose from the map points; the parallax from it: the median angle between
    // the rays from the last keyframe and from this frame to the tracked points (the
    // triangulation angle the gate measures; rotation does not count).
    ++frames_since_keyframe_;
    Track(gray, &step);
    if (!step.tracked) {
      step.keyframe_reason = "tracking lost";
    } else {
      last_decision_ = GateDecision{};
      last_decision_.tracks = step.tracked_points;
      last_decision_.median_parallax_deg = MedianTriangulationAngleDeg(step.cam_from_segment);
      step.decision = last_decision_;
      if (step.tracked_points < options_.min_tracked_share * seeded_points_ ||
          step.tracked_points < options_.min_tracked_points) {
        step.keyframe_reason = "tracking weak";
      } else if (last_decision_.median_parallax_deg >= options_.gate.parallax_deg) {
        step.keyframe_reason = "parallax";
      }
    }
  } else {
    // Not tracking (a segment's first keyframe, or lost): the keyframe gate's tracks.
    ++frames_since_keyframe_;
    step.decision = gate_.Update(gray);
    last_decision_ = step.decision;
    previous_ = gray.clone();
    if (map_.lost()) {
      if (frames_since_keyframe_ >= options_.lost_retry_frames) {
        step.keyframe_reason = "relocalisation";
      }
    } else if (step.decision.verdict == GateDecision::Verdict::kTakeB) {
      step.keyframe_reason = "parallax";
    } else if (step.decision.verdict == GateDecision::Verdict::kLostTrack) {
      step.keyframe_reason = "gate lost track";
    }
  }
  if (step.keyframe_reason.empty()) return step;
  const bool prior = step.tracked && step.segment == map_.current_segment();
  step.added = map_.AddKeyframe(gray, timestamp_s, prior ? &step.cam_from_segment : nullptr);
  frames_since_keyframe_ = 0;
  Seed(gray);
  if (segment_ < 0) gate_.Start(gray);
  step.tracked = step.added->registered;
  if (step.tracked) {
    step.segment = step.added->segment;
    step.cam_from_segment = map_.keyframes().back().cam_from_segment;
  }
  return step;
}

}  // namespace mm
