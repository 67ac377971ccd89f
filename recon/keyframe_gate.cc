#include "recon/keyframe_gate.h"

#include <algorithm>
#include <cmath>
#include <opencv2/imgproc.hpp>
#include <opencv2/video/tracking.hpp>

namespace mm {

std::string KeyframeGateOptions::Check() const {
  if (!(parallax_deg > 0)) return "parallax_deg: must be > 0";
  if (parallax_deg < two_view.min_median_triangulation_angle_deg) {
    return "parallax_deg: must be >= the reconstruction's minimum median triangulation angle (" +
           std::to_string(two_view.min_median_triangulation_angle_deg) +
           " deg), or B would be refused";
  }
  if (max_corners < 8) return "max_corners: must be >= 8";
  if (min_tracks < 8) return "min_tracks: must be >= 8";
  if (min_inliers < 8) return "min_inliers: must be >= 8";
  if (early_b_tracks < 0) return "early_b_tracks: must be >= 0";
  if (ransac_iterations < 10) return "ransac_iterations: must be >= 10";
  return two_view.Check();
}

std::vector<cv::Point2f> DetectGateCorners(const cv::Mat& gray_a,
                                           const KeyframeGateOptions& options) {
  CV_Assert(gray_a.type() == CV_8UC1);
  std::vector<cv::Point2f> corners;
  cv::goodFeaturesToTrack(gray_a, corners, options.max_corners, options.corner_quality,
                          options.min_corner_distance_px);
  return corners;
}

void TrackForwardBackward(const cv::Mat& from, const cv::Mat& to,
                          const KeyframeGateOptions& options, std::vector<cv::Point2f>* origins_a,
                          std::vector<cv::Point2f>* points) {
  CV_Assert(to.type() == CV_8UC1 && to.size() == from.size());
  CV_Assert(origins_a->size() == points->size());
  if (points->size() < 8) {
    origins_a->clear();
    points->clear();
    return;
  }
  // Track forward, then back: keep tracks that return to where they started (Kalal et al.,
  // forward-backward error, ICPR 2010).
  const cv::Size window(options.klt_window_px, options.klt_window_px);
  const cv::TermCriteria criteria(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, 20, 0.03);
  std::vector<cv::Point2f> next, back;
  std::vector<uchar> status, status_back;
  std::vector<float> error, error_back;
  cv::calcOpticalFlowPyrLK(from, to, *points, next, status, error, window, options.klt_levels,
                           criteria);
  cv::calcOpticalFlowPyrLK(to, from, next, back, status_back, error_back, window,
                           options.klt_levels, criteria);
  std::vector<cv::Point2f> kept_a, kept_next;
  for (size_t i = 0; i < next.size(); ++i) {
    const bool inside =
        next[i].x >= 0 && next[i].y >= 0 && next[i].x < to.cols - 1 && next[i].y < to.rows - 1;
    const float fb = static_cast<float>(cv::norm(back[i] - (*points)[i]));
    if (status[i] && status_back[i] && inside && error[i] < options.max_klt_error &&
        fb < options.max_forward_backward_px) {
      kept_a.push_back((*origins_a)[i]);
      kept_next.push_back(next[i]);
    }
  }
  *origins_a = std::move(kept_a);
  *points = std::move(kept_next);
}

std::vector<GateWaypoint> TrackBackFromA(const cv::Mat& gray_a,
                                         std::span<const cv::Mat> frames_before_a,
                                         const KeyframeGateOptions& options) {
  std::vector<GateWaypoint> out;
  std::vector<cv::Point2f> origins_a = DetectGateCorners(gray_a, options);
  std::vector<cv::Point2f> points = origins_a;
  const cv::Mat* previous = &gray_a;
  for (const cv::Mat& frame : frames_before_a) {
    TrackForwardBackward(*previous, frame, options, &origins_a, &points);
    if (static_cast<int>(points.size()) < options.min_tracks) break;
    out.push_back(GateWaypoint{frame, origins_a, points, 0.0});
    previous = &frame;
  }
  return out;
}

KeyframeGate::KeyframeGate(const Eigen::Matrix3d& K, KeyframeGateOptions options)
    : K_(K), options_(options), target_parallax_deg_(options.parallax_deg) {}

int KeyframeGate::Start(const cv::Mat& gray_a) {
  points_a_ = DetectGateCorners(gray_a, options_);
  points_prev_ = points_a_;
  previous_ = gray_a.clone();
  target_parallax_deg_ = options_.parallax_deg;
  halfway_ = GateWaypoint{};
  return static_cast<int>(points_a_.size());
}

GateDecision KeyframeGate::Update(const cv::Mat& gray) {
  CV_Assert(gray.type() == CV_8UC1 && gray.size() == previous_.size());
  GateDecision d;
  TrackForwardBackward(previous_, gray, options_, &points_a_, &points_prev_);
  previous_ = gray.clone();
  d.tracks = static_cast<int>(points_a_.size());
  if (d.tracks < options_.min_tracks) {
    d.verdict = GateDecision::Verdict::kLostTrack;
    d.reason = "lost track (" + std::to_string(d.tracks) + " tracks left, need " +
               std::to_string(options_.min_tracks) + ")";
    return d;
  }

  // The reconstruction's own test on the tracks (ProbeTwoView): same thresholds and
  // classification, fewer RANSAC samples (tracks are mostly inliers; the gate runs per frame).
  std::vector<Eigen::Vector2d> pixels_a, pixels_b;
  pixels_a.reserve(points_a_.size());
  pixels_b.reserve(points_a_.size());
  for (size_t i = 0; i < points_a_.size(); ++i) {
    pixels_a.emplace_back(points_a_[i].x, points_a_[i].y);
    pixels_b.emplace_back(points_prev_[i].x, points_prev_[i].y);
  }
  TwoViewOptions probe_options = options_.two_view;
  probe_options.max_ransac_iterations =
      std::min(probe_options.max_ransac_iterations, options_.ransac_iterations);
  probe_options.min_inliers = options_.min_inliers;
  probe_options.f_refine_iterations = options_.f_refine_iterations;
  const TwoViewProbe probe = ProbeTwoView(pixels_a, pixels_b, K_, probe_options);
  d.essential_inliers =
      probe.ransac_f.success ? static_cast<int>(probe.ransac_f.inliers.size()) : 0;
  d.homography_inliers = probe.classification.h_inliers;
  d.median_parallax_deg = probe.median_triangulation_angle_deg;
  d.failure = probe.failure;
  // The probe already held the angle against the reconstruction's minimum.
  const bool running_out =
      d.tracks < options_.early_b_tracks && target_parallax_deg_ <= options_.parallax_deg;
  if (!probe.accepted) {
    d.reason = probe.failure_reason;
  } else if (running_out) {
    d.verdict = GateDecision::Verdict::kTakeB;
    d.reason = "tracks running out (" + std::to_string(d.tracks) +
               "); the reconstruction's minimum is met";
  } else if (d.median_parallax_deg < target_parallax_deg_) {
    d.reason = "not enough parallax yet";
  } else {
    d.verdict = GateDecision::Verdict::kTakeB;
    d.reason = "parallax reached";
  }
  // About halfway to B: of the frames before B, the one whose angle is nearest half the
  // required one (the gate may skip frames when it falls behind, so "the last one below half"
  // can sit next to A); a frame without an angle only while none was measured.
  if (d.verdict != GateDecision::Verdict::kTakeB) {
    const double half = 0.5 * target_parallax_deg_;
    const bool measured = d.median_parallax_deg > 0;
    const bool held = halfway_.parallax_deg > 0;
    if (measured ? (!held || std::abs(d.median_parallax_deg - half) <=
                                 std::abs(halfway_.parallax_deg - half))
                 : !held) {
      halfway_ = GateWaypoint{previous_, points_a_, points_prev_, d.median_parallax_deg};
    }
  }
  return d;
}

}  // namespace mm
