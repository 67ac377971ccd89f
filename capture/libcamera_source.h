#pragma once
// A libcamera camera (libcamera 0.0.3, Debian 12): one viewfinder stream, frames converted to
// BGR8 or GRAY8. URI: libcamera:<camera id or index>?width=&height=&format=&gray=&timeout_ms=
//
// libcamera runs in a worker process (mm-libcamera-worker; capture/libcamera_ipc.h says why);
// this process maps the worker's frame buffers and converts frames in place.
//
// Recovery as V4l2Source: a camera disconnected (libcamera's signal), silent for
// `lost_after_ms`, or whose worker died is torn down (the worker killed) and reported lost
// once; later Reads start a new worker, which looks the camera up again by id, with back-off,
// and capture resumes.

#include <sys/types.h>

#include <chrono>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "base/unique_fd.h"
#include "capture/frame.h"
#include "capture/pixel_format.h"
#include "capture/recovery.h"

namespace mm {

/// A child process started with posix_spawn: killed (SIGKILL) and reaped on destruction.
class WorkerProcess {
 public:
  WorkerProcess() = default;
  ~WorkerProcess() { Kill(); }
  WorkerProcess(const WorkerProcess&) = delete;
  WorkerProcess& operator=(const WorkerProcess&) = delete;

  /// Starts `argv[0]` connected by a SOCK_SEQPACKET pair: the child's end is its fd 3
  /// (lcipc::kSocketFd), ours goes to `parent_socket`. Behind the command prefix in
  /// $MM_LIBCAMERA_WORKER_LAUNCHER if set (e.g. an emulator). Returns an error or "".
  [[nodiscard]] std::string Spawn(const std::vector<std::string>& argv, UniqueFd* parent_socket);
  /// Waits up to `timeout` for the child to exit on its own, then kills it; reaps it.
  /// Returns how it ended ("exited 0", "killed by signal 11 (Segmentation fault)").
  std::string Reap(std::chrono::milliseconds timeout);
  void Kill() { Reap(std::chrono::milliseconds(0)); }
  [[nodiscard]] pid_t pid() const { return pid_; }

 private:
  pid_t pid_ = -1;
};

struct LibcameraOptions {
  std::string camera;                 ///< Camera id, or an index into the list ("0").
  int width = 0, height = 0;          ///< 0: the pipeline's default size.
  std::optional<PixelFormat> format;  ///< nullopt: a convertible format the stream offers.
  bool gray = false;
  int lost_after_ms = 3000;
  int reopen_min_ms = 100, reopen_max_ms = 2000;
  int open_timeout_ms = 10000;  ///< For the worker to start libcamera and configure the camera.
  /// The worker executable; empty: LibcameraWorkerPath().
  std::string worker;
};

/// Where mm-libcamera-worker is: $MM_LIBCAMERA_WORKER, else next to this executable, else the
/// installed libexec path, else the build tree's.
std::string LibcameraWorkerPath();

/// The ids of the cameras libcamera lists on this machine (asks a worker).
std::vector<std::string> ListLibcameraCameras(std::string* error);

class LibcameraSource final : public FrameSource {
 public:
  explicit LibcameraSource(LibcameraOptions options);
  ~LibcameraSource() override;

  [[nodiscard]] std::string Open() override;
  [[nodiscard]] ReadStatus Read(Frame* frame, std::chrono::milliseconds timeout,
                                std::string* error) override;
  void Close() override;
  [[nodiscard]] std::string Describe() const override;

  [[nodiscard]] uint64_t losses() const { return recovery_.losses(); }
  [[nodiscard]] uint64_t reopens() const { return recovery_.reopens(); }
  /// The running worker's pid (-1 when none), for tests that kill it.
  [[nodiscard]] pid_t worker_pid() const { return worker_.pid(); }

 private:
  struct Mapping {
    void* addr = nullptr;
    size_t length = 0;
    size_t offset = 0;  ///< Of plane 0.
  };
  /// The camera's resolved id once known, else the id or index asked for.
  [[nodiscard]] const std::string& Name() const { return id_.empty() ? options_.camera : id_; }
  [[nodiscard]] std::string OpenCamera();
  /// Ends the worker (politely when `stop`, else SIGKILL) and unmaps its buffers.
  void CloseCamera(bool stop);
  std::string Lose(const std::string& why);

  LibcameraOptions options_;
  WorkerProcess worker_;
  UniqueFd socket_;
  std::vector<Mapping> mappings_;  // One per buffer (planes of one buffer share the dmabuf).
  bool opened_ = false;
  std::string id_;

  PixelFormat format_ = PixelFormat::kYuyv;
  int width_ = 0, height_ = 0;
  size_t stride_ = 0;
  MjpegDecoder decoder_;
  uint64_t sequence_ = 0;
  DeviceRecovery recovery_;
  mutable std::mutex describe_mutex_;
  std::string description_;
};

}  // namespace mm
