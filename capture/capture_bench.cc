// Benchmark of the capture thread's software paths: 1280x720 frames replayed at 30 fps (paced,
// as a camera delivers them) and as fast as possible, through YUYV -> BGR, YUYV -> gray,
// NV12 -> BGR and MJPEG decode (BGR and gray), each behind a real CaptureThread with a consumer
// that takes every frame it can. Reports frames delivered, frames dropped and CPU time per
// frame of the capture thread. Not a ctest: run build/default/capture/capture_capture_bench.
// Usage: capture_capture_bench [seconds per run, default 3]

#include <time.h>

#include <cstdio>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <string>
#include <thread>
#include <vector>

#include "capture/capture_thread.h"
#include "capture/pixel_format.h"

namespace mm {
namespace {

int64_t ThreadCpuNs() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return static_cast<int64_t>(ts.tv_sec) * 1000000000LL + ts.tv_nsec;
}

// A synthetic camera: cycles pre-encoded frames in one wire format, paced or not, converting
// exactly as V4l2Source does. Records its own CPU time.
class SyntheticSource final : public FrameSource {
 public:
  SyntheticSource(PixelFormat format, bool gray, double fps, std::vector<std::string> frames,
                  int width, int height, int64_t* cpu_ns)
      : format_(format), gray_(gray), fps_(fps), frames_(std::move(frames)), width_(width),
        height_(height), cpu_ns_(cpu_ns) {}
  std::string Open() override {
    next_ = MonotonicNowNs();
    return {};
  }
  ReadStatus Read(Frame* frame, std::chrono::milliseconds, std::string* error) override {
    if (fps_ > 0) {
      next_ += static_cast<int64_t>(1e9 / fps_);
      const int64_t wait = next_ - MonotonicNowNs();
      if (wait > 0) std::this_thread::sleep_for(std::chrono::nanoseconds(wait));
    }
    const int64_t c0 = ThreadCpuNs();
    const std::string& raw = frames_[seq_ % frames_.size()];
    const auto* data = reinterpret_cast<const uint8_t*>(raw.data());
    std::string e =
        ConvertFrame(format_, data, raw.size(), width_, height_, 0, gray_, &decoder_, &frame->image);
    *cpu_ns_ += ThreadCpuNs() - c0;
    if (!e.empty()) {
      *error = e;
      return ReadStatus::kError;
    }
    frame->sequence = seq_++;
    frame->capture_time_ns = MonotonicNowNs();
    return ReadStatus::kFrame;
  }
  void Close() override {}
  [[nodiscard]] std::string Describe() const override { return PixelFormatName(format_); }

 private:
  PixelFormat format_;
  bool gray_;
  double fps_;
  std::vector<std::string> frames_;
  int width_, height_;
  int64_t* cpu_ns_;
  MjpegDecoder decoder_;
  uint64_t seq_ = 0;
  int64_t next_ = 0;
};

std::vector<std::string> MakeFrames(PixelFormat format, int w, int h) {
  std::vector<std::string> out;
  for (int i = 0; i < 4; ++i) {
    cv::Mat bgr(h, w, CV_8UC3);
    cv::randu(bgr, 0, 256);
    cv::GaussianBlur(bgr, bgr, cv::Size(9, 9), 3.0);  // Camera-like, compressible content.
    cv::putText(bgr, "frame " + std::to_string(i), {100, 300}, cv::FONT_HERSHEY_SIMPLEX, 4, {255, 255, 255}, 8);
    std::string bytes;
    if (format == PixelFormat::kYuyv) {
      BgrToYuyv(bgr, &bytes);
    } else if (format == PixelFormat::kNv12) {
      cv::Mat i420;
      cv::cvtColor(bgr, i420, cv::COLOR_BGR2YUV_I420);
      bytes.assign(reinterpret_cast<const char*>(i420.data), static_cast<size_t>(w) * h);
      const uint8_t* u = i420.data + static_cast<size_t>(w) * h;
      const uint8_t* v = u + static_cast<size_t>(w) * h / 4;
      for (size_t k = 0; k < static_cast<size_t>(w) * h / 4; ++k) {
        bytes.push_back(static_cast<char>(u[k]));
        bytes.push_back(static_cast<char>(v[k]));
      }
    } else {
      std::vector<uint8_t> jpeg;
      cv::imencode(".jpg", bgr, jpeg, {cv::IMWRITE_JPEG_QUALITY, 85});
      bytes.assign(jpeg.begin(), jpeg.end());
    }
    out.push_back(std::move(bytes));
  }
  return out;
}

}  // namespace
}  // namespace mm

int main(int argc, char** argv) {
  using namespace mm;
  const double seconds = argc > 1 ? std::stod(argv[1]) : 3.0;
  const int w = 1280, h = 720;
  std::printf("%-14s %-6s %8s %9s %8s %12s %10s\n", "path", "rate", "frames", "consumed", "dropped",
              "cpu ms/frame", "fps");
  struct Path {
    const char* name;
    PixelFormat format;
    bool gray;
  };
  const Path paths[] = {{"yuyv->bgr", PixelFormat::kYuyv, false},
                        {"yuyv->gray", PixelFormat::kYuyv, true},
                        {"nv12->bgr", PixelFormat::kNv12, false},
                        {"mjpeg->bgr", PixelFormat::kMjpeg, false},
                        {"mjpeg->gray", PixelFormat::kMjpeg, true}};
  for (const Path& p : paths) {
    const auto frames = MakeFrames(p.format, w, h);
    for (const double fps : {30.0, 0.0}) {
      int64_t cpu_ns = 0;
      CaptureThread thread(std::make_unique<SyntheticSource>(p.format, p.gray, fps, frames, w, h, &cpu_ns), {});
      if (std::string e = thread.Start(); !e.empty()) {
        std::fprintf(stderr, "%s\n", e.c_str());
        return 1;
      }
      // A consumer that takes each newest frame and spends ~1 ms on it (a KLT step's order).
      int64_t consumed = 0, last = -1;
      const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(seconds);
      while (std::chrono::steady_clock::now() < end) {
        FramePtr f = thread.WaitNewer(last, std::chrono::milliseconds(100));
        if (!f) continue;
        last = static_cast<int64_t>(f->sequence);
        ++consumed;
        std::this_thread::sleep_for(std::chrono::milliseconds(1));
      }
      thread.Stop();
      const CaptureStats st = thread.stats();
      std::printf("%-14s %-6s %8llu %9lld %8llu %12.2f %10.1f\n", p.name, fps > 0 ? "30fps" : "max",
                  static_cast<unsigned long long>(st.frames), static_cast<long long>(consumed),
                  static_cast<unsigned long long>(st.dropped),
                  st.frames ? static_cast<double>(cpu_ns) / 1e6 / static_cast<double>(st.frames) : 0.0,
                  static_cast<double>(st.frames) / seconds);
    }
  }
  return 0;
}
