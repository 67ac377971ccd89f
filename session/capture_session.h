#pragma once
// One capture from keyframe A to an accepted pair, as a state machine over frames and the
// reconstruction's verdicts (no threads, no clock: times are given), shared by the daemon and
// `monomesh eval --captures` so both run the same gate and the same policy:
//   Start (keyframe A) -> OnFrame per frame: the keyframe gate (recon/keyframe_gate.h) tracks
//   A's corners and says when the reconstruction will accept the pair -> kSubmitB: the caller
//   reconstructs A with this B (and the gate's tracks) -> OnResult: an entry ends the capture;
//   a refusal that more motion can cure (MoreMotionMayCure: too little parallax, rotation,
//   planar, no clear cheirality winner) keeps tracking from A and asks the next B for more
//   parallax than the refused one; any other refusal, lost track or the timeout ends it. When
//   the tracks break, the frame that broke them goes to the reconstruction as a last B.
// While a B is being reconstructed the gate keeps tracking, so a retry can follow at once.
//
// Thread-safety: thread-bound (one session per capture, driven by one thread).

#include <Eigen/Core>
#include <cstdint>
#include <opencv2/core.hpp>
#include <span>
#include <string>
#include <vector>

#include "recon/keyframe_gate.h"
#include "recon/pipeline.h"

namespace mm {

struct CaptureSessionOptions {
  KeyframeGateOptions gate;
  double timeout_s = 30.0;  ///< No accepted B this long after A: the capture fails.
  /// After a refused B, the next must reach this factor times the refused B's gate parallax.
  double retry_parallax_growth = 1.25;
  int max_tries = 10;  ///< B reconstructions per capture at most.
  /// When the tracks break with no B in flight, hand the frame that broke them to the
  /// reconstruction as a last B (its descriptor matching spans jumps KLT cannot) before
  /// ending the capture as lost.
  bool b_after_lost_track = true;
  [[nodiscard]] std::string Check() const;
};

/// A frame the gate tracked A's corners to, as a source view for the dense stage.
SourceView SourceViewOf(const GateWaypoint& waypoint);

/// Source views before A: A's corners tracked back through `frames_before_a` (8-bit gray,
/// undistorted, A's size, newest first; e.g. RecentFrames::BeforeA) by TrackBackFromA.
std::vector<SourceView> ViewsBeforeA(const cv::Mat& gray_a,
                                     std::span<const cv::Mat> frames_before_a,
                                     const KeyframeGateOptions& options);

/// One keyframe B handed to the reconstruction, and what it said.
struct KeyframeBTry {
  uint64_t frame_sequence = 0;
  double seconds_after_a = 0.0;    ///< Frame time of B minus that of A.
  double gate_parallax_deg = 0.0;  ///< The gate's median triangulation angle at B.
  int tracks = 0;
  /// Taken because the tracks broke (no gate verdict; see b_after_lost_track).
  bool after_lost_track = false;
  bool accepted = false;
  TwoViewFailure failure = TwoViewFailure::kNone;
  std::string reason;  ///< The reconstruction's failure reason (empty when accepted).
};

/// How a capture ended (kOpen while it runs).
enum class CaptureEnd {
  kOpen,
  kAccepted,      ///< The reconstruction accepted a B: an entry.
  kRefused,       ///< The reconstruction refused B for a reason more motion cannot cure.
  kLostTrack,     ///< Too few tracks left (after the refused B tries, if any).
  kTimeout,       ///< No accepted B within timeout_s ("not enough motion").
  kTooManyTries,  ///< max_tries B refused.
  kAborted,       ///< Ended from outside (Abort: a camera or worker error).
};
/// "accepted", "refused", "lost_track", "not_enough_motion", "too_many_tries", "aborted".
const char* CaptureEndName(CaptureEnd end);

class CaptureSession {
 public:
  enum class Step {
    kWait,     ///< Nothing to do: keep feeding frames (or wait for the result).
    kSubmitB,  ///< Reconstruct A with this frame as B (Tracks() are its correspondences).
    kDone,     ///< The reconstruction accepted B: the capture is over, with an entry.
    kFailed,   ///< The capture is over without one: failure_reason() says why.
  };

  CaptureSession(const Eigen::Matrix3d& K, CaptureSessionOptions options);

  /// Opens a capture on keyframe A (8-bit gray, undistorted) at frame time `time_s`. Returns
  /// the number of corners found.
  int Start(const cv::Mat& gray_a, double time_s);

  /// One newer frame (8-bit gray, undistorted). `can_submit`: the reconstruction is idle, so
  /// a B may be handed to it now (otherwise the gate only keeps its tracks alive).
  /// Track, then OnTracked.
  Step OnFrame(const cv::Mat& gray, uint64_t sequence, double time_s, bool can_submit);

  /// The session takes frames (open, and the tracks have not broken).
  [[nodiscard]] bool wants_frames() const { return open_ && !lost_; }
  /// OnFrame in two halves, for a caller that tracks off its event loop: Track is the gate's
  /// work on the frame (KLT and the two-view probe: the expensive part). It touches the gate
  /// only, so it may run on another thread meanwhile the caller may call anything but the
  /// methods that touch the gate too: Start, OnFrame, OnResult, Tracks and Between. OnTracked
  /// applies the capture's policy to its decision (ignored when the session no longer wants
  /// frames).
  GateDecision Track(const cv::Mat& gray);
  Step OnTracked(const GateDecision& decision, uint64_t sequence, double time_s, bool can_submit);

  /// The reconstruction's verdict on the B of the last kSubmitB.
  Step OnResult(bool accepted, TwoViewFailure failure, const std::string& reason);

  /// Without a frame (a timer): kFailed once the timeout has passed with no B in flight.
  Step OnTime(double time_s);

  /// Ends the capture from outside (a camera or worker error); a no-op when already ended.
  void Abort(const std::string& reason) {
    if (open_) Fail(CaptureEnd::kAborted, reason);
  }

  [[nodiscard]] bool open() const { return open_; }
  [[nodiscard]] CaptureEnd end() const { return end_; }
  [[nodiscard]] bool b_in_flight() const { return in_flight_; }
  [[nodiscard]] const GateDecision& last_decision() const { return last_decision_; }
  [[nodiscard]] const std::vector<KeyframeBTry>& tries() const { return tries_; }
  [[nodiscard]] const std::string& failure_reason() const { return failure_reason_; }
  /// The gate's tracks from A to the last frame, as correspondences for the reconstruction.
  [[nodiscard]] std::vector<TrackCorrespondence> Tracks() const;
  /// The frame about halfway from A to the last frame, with the tracks' correspondences at it,
  /// for the dense stage (empty when the gate has tracked none).
  [[nodiscard]] std::vector<SourceView> Between() const;
  /// "n refused: reason (k); reason (m)" over the refused tries, for messages.
  [[nodiscard]] std::string RefusalSummary() const;

 private:
  Step Fail(CaptureEnd end, std::string reason);
  Step SubmitB(uint64_t sequence, double time_s, bool after_lost_track);
  [[nodiscard]] std::string LostTrackReason() const;

  CaptureSessionOptions options_;
  KeyframeGate gate_;
  bool open_ = false;
  CaptureEnd end_ = CaptureEnd::kOpen;
  bool in_flight_ = false;
  bool lost_ = false;  // The tracks broke: the B in flight is the last.
  std::string lost_reason_;
  double start_time_s_ = 0.0;
  GateDecision last_decision_;
  std::vector<KeyframeBTry> tries_;
  std::string failure_reason_;
};

}  // namespace mm
