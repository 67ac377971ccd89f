#pragma once
// `test:<pattern>` frames made in memory, for unit tests of the daemon and the capture thread
// without a dataset or a device:
//   test:still?width=320&height=240&fps=30&frames=0&gray=0|1   a fixed random-block texture
//   test:pan?...                                               the texture moving 1 px/frame
// Frames come at `fps` (paced like a camera), sequence from 0, source time sequence / fps;
// frames=N ends the stream after N frames (0 = endless).
//
// Thread-safety: thread-bound (see FrameSource).

#include <chrono>
#include <opencv2/core.hpp>
#include <string>

#include "capture/frame.h"

namespace mm {

struct TestPatternOptions {
  std::string pattern = "still";  ///< "still" or "pan".
  int width = 320;
  int height = 240;
  double fps = 30.0;
  uint64_t frames = 0;  ///< End of stream after this many; 0 = endless.
  bool gray = false;
};

class TestPatternSource : public FrameSource {
 public:
  explicit TestPatternSource(TestPatternOptions options);
  [[nodiscard]] std::string Open() override;
  [[nodiscard]] ReadStatus Read(Frame* frame, std::chrono::milliseconds timeout,
                                std::string* error) override;
  void Close() override;
  [[nodiscard]] std::string Describe() const override;

 private:
  TestPatternOptions options_;
  cv::Mat texture_;  // Twice the frame size, so the pan has room.
  uint64_t next_ = 0;
  std::chrono::steady_clock::time_point start_;
};

}  // namespace mm
