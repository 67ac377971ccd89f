#pragma once
// The virtual camera of the tests and the demo: plays a TUM-format folder (a `timestamp path`
// list, rgb.txt by default) at its recorded rate, scaled by `speed`, or as fast as possible.

#include <filesystem>
#include <string>
#include <vector>

#include "capture/frame.h"
#include "dataset/tum.h"

namespace mm {

/// A looping replay at its recorded rate keeps its decoded frames when all of them fit in this
/// many bytes (the bundled 6-frame folder: 5.5 MB), so later passes decode nothing: the PNG
/// decoder was most of a looping camera's CPU. A larger folder is decoded every pass (the
/// corridor's 300 frames would add 276 MB to the daemon's resident set). At `rate=max` the
/// decoder paces the camera, which is otherwise a spin of frames nobody takes.
inline constexpr size_t kReplayLoopCacheBytes = size_t{16} << 20;

/// Playback speed factors accepted (`speed=` in the URI).
inline constexpr double kMinReplaySpeed = 0.001;
inline constexpr double kMaxReplaySpeed = 1000.0;
/// The longest gap between neighbouring timestamps of a replayed list: a recording pauses for
/// seconds, not minutes; a larger gap is a broken list, not a camera that waits.
inline constexpr double kMaxReplayGapS = 60.0;

struct ReplayOptions {
  std::string list = "rgb.txt";  ///< The list file inside the folder.
  bool realtime = true;          ///< Pace by the recorded timestamps; false: as fast as possible.
  double speed = 1.0;            ///< Playback speed factor when realtime (> 0).
  bool loop = false;             ///< Start again after the last frame instead of ending.
  bool gray = false;             ///< Deliver GRAY8 instead of BGR8.
  int width = 0;                 ///< Resize frames to width x height (0: as recorded), e.g. to
  int height = 0;                ///< replay a dataset as a camera of another resolution.

  /// Empty when valid, else a message naming the bad option.
  [[nodiscard]] std::string Check() const;
};

class ReplaySource final : public FrameSource {
 public:
  ReplaySource(std::filesystem::path folder, ReplayOptions options);

  [[nodiscard]] std::string Open() override;
  [[nodiscard]] ReadStatus Read(Frame* frame, std::chrono::milliseconds timeout,
                                std::string* error) override;
  void Close() override;
  [[nodiscard]] std::string Describe() const override;

 private:
  std::filesystem::path folder_;
  ReplayOptions options_;
  std::vector<TumFrame> frames_;
  size_t next_ = 0;
  uint64_t sequence_ = 0;
  int64_t start_ns_ = 0;        // Wall time of frame 0 of the current pass.
  double pass_offset_s_ = 0.0;  // Dataset time added per completed loop pass.
  // With loop and realtime: a slot per frame for its decoded image of the first pass, shared
  // (frames are read-only once published); empty when not caching, or for good once the
  // frames do not fit kReplayLoopCacheBytes.
  std::vector<cv::Mat> decoded_;
};

}  // namespace mm
