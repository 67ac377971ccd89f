#include "capture/libcamera_source.h"

#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <sys/mman.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <filesystem>
#include <sstream>
#include <thread>

#include "base/poll.h"
#include "base/process.h"
#include "capture/libcamera_ipc.h"
#include "capture/source_uri.h"

namespace mm {
namespace {

using Clock = std::chrono::steady_clock;
using lcipc::MsgType;

// Largest message the worker sends.
union WorkerMessage {
  MsgType type;
  lcipc::Configured configured;
  lcipc::FrameReady frame;
  lcipc::Text text;
};

/// Waits for one worker message until `deadline`: > 0 its size, 0 EOF, -1 error, -2 timeout.
long ReceiveBefore(int socket, Clock::time_point deadline, WorkerMessage* m,
                   std::vector<UniqueFd>* fds) {
  const int r = PollReadable(socket, deadline);
  if (r == 0) return -2;
  if (r < 0) return -1;
  return lcipc::Receive(socket, m, sizeof(*m), fds);
}

}  // namespace

std::string WorkerProcess::Spawn(const std::vector<std::string>& argv, UniqueFd* parent_socket) {
  Kill();
  parent_socket->reset();
  int sv[2];
  if (socketpair(AF_UNIX, SOCK_SEQPACKET | SOCK_CLOEXEC, 0, sv) != 0) {
    return std::string("socketpair: ") + strerror(errno);
  }
  UniqueFd parent(sv[0]), child(sv[1]);
  // dup2 onto the same number would keep close-on-exec: move the child's end out of the way.
  if (child.get() == lcipc::kSocketFd) child.reset(fcntl(sv[1], F_DUPFD_CLOEXEC, 10));
  const int socket = child.get();
  // Checked here: a failed exec is not reported by posix_spawn everywhere (qemu-user: exit 127).
  if (access(argv[0].c_str(), X_OK) != 0) return "cannot start " + argv[0] + ": " + strerror(errno);
  // An optional command prefix (an emulator, a debugger): "qemu-aarch64-static -L /sysroot".
  std::vector<std::string> command;
  if (const char* launcher = std::getenv("MM_LIBCAMERA_WORKER_LAUNCHER"); launcher && *launcher) {
    std::istringstream words(launcher);
    for (std::string w; words >> w;) command.push_back(w);
  }
  command.insert(command.end(), argv.begin(), argv.end());
  // Its own process group: a terminal's ^C is for the daemon, which then stops the worker.
  pid_t pid = -1;
  if (std::string error = SpawnProcess(command, {.dup2 = {{socket, lcipc::kSocketFd}}}, &pid);
      !error.empty()) {
    return error;
  }
  pid_ = pid;
  *parent_socket = std::move(parent);  // The child's end closes here, in this process.
  return {};
}

std::string WorkerProcess::Reap(std::chrono::milliseconds timeout) {
  if (pid_ < 0) return "not running";
  const auto deadline = Clock::now() + timeout;
  int status = 0;
  pid_t r = 0;
  while ((r = waitpid(pid_, &status, WNOHANG)) == 0 && Clock::now() < deadline) {
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  if (r == 0) {
    kill(pid_, SIGKILL);
    while ((r = waitpid(pid_, &status, 0)) < 0 && errno == EINTR) {
    }
  }
  pid_ = -1;
  return r < 0 ? std::string("lost (waitpid: ") + strerror(errno) + ")"
               : DescribeWaitStatus(status);
}

std::string LibcameraWorkerPath() {
  namespace fs = std::filesystem;
  const char* name = "mm-libcamera-worker";
  if (const char* env = std::getenv("MM_LIBCAMERA_WORKER"); env && *env) return env;
  std::error_code ec;
  const fs::path self = fs::read_symlink("/proc/self/exe", ec);
  if (!ec && fs::exists(self.parent_path() / name, ec)) return self.parent_path() / name;
  if (fs::exists(MM_LIBCAMERA_WORKER_INSTALLED, ec)) return MM_LIBCAMERA_WORKER_INSTALLED;
  if (fs::exists(MM_LIBCAMERA_WORKER_BUILT, ec)) return MM_LIBCAMERA_WORKER_BUILT;
  return MM_LIBCAMERA_WORKER_INSTALLED;
}

std::vector<std::string> ListLibcameraCameras(std::string* error) {
  std::vector<std::string> ids;
  UniqueFd socket;
  WorkerProcess worker;
  if (const std::string e = worker.Spawn({LibcameraWorkerPath(), "--list"}, &socket); !e.empty()) {
    if (error) *error = "libcamera: " + e;
    return ids;
  }
  WorkerMessage m{};
  const long n = ReceiveBefore(socket.get(), Clock::now() + std::chrono::seconds(20), &m, nullptr);
  if (n > 0 && m.type == MsgType::kCameras) {
    std::istringstream lines(m.text.text);
    for (std::string id; std::getline(lines, id);) {
      if (!id.empty()) ids.push_back(id);
    }
  } else if (error) {
    *error = "libcamera: " + (n > 0 && m.type == MsgType::kError
                                  ? std::string(m.text.text)
                                  : "worker " + worker.Reap(std::chrono::seconds(1)));
  }
  worker.Reap(std::chrono::seconds(2));
  return ids;
}

LibcameraSource::LibcameraSource(LibcameraOptions options)
    : options_(std::move(options)),
      recovery_({options_.lost_after_ms, options_.reopen_min_ms, options_.reopen_max_ms}) {
  description_ = "libcamera:" + options_.camera + " (not open)";
}

LibcameraSource::~LibcameraSource() { Close(); }

std::string LibcameraSource::Open() {
  Close();
  if (std::string e = OpenCamera(); !e.empty()) return e;
  opened_ = true;
  recovery_.Reset();
  return {};
}

std::string LibcameraSource::OpenCamera() {
  const std::string& want = Name();
  const std::string where = "libcamera " + want + ": ";
  const std::string path = options_.worker.empty() ? LibcameraWorkerPath() : options_.worker;
  std::vector<std::string> argv = {path, "--camera", want};
  if (options_.width > 0) {
    argv.insert(argv.end(), {"--width", std::to_string(options_.width), "--height",
                             std::to_string(options_.height)});
  }
  if (options_.format) argv.insert(argv.end(), {"--format", PixelFormatName(*options_.format)});
  if (const std::string e = worker_.Spawn(argv, &socket_); !e.empty()) return where + e;
  WorkerMessage m{};
  std::vector<UniqueFd> fds;
  const long n = ReceiveBefore(
      socket_.get(), Clock::now() + std::chrono::milliseconds(options_.open_timeout_ms), &m, &fds);
  if (n <= 0 || m.type != MsgType::kConfigured) {
    std::string why;
    if (n == -2) {
      why = "the camera worker did not configure the camera within " +
            std::to_string(options_.open_timeout_ms) + " ms";
    } else if (n > 0 && m.type == MsgType::kError) {
      why = m.text.text;
    } else {
      why = "the camera worker " + worker_.Reap(std::chrono::seconds(1)) + " (" + path + ")";
    }
    CloseCamera(false);
    return where + why;
  }
  const lcipc::Configured& c = m.configured;
  if (fds.size() != c.buffers || c.buffers == 0) {
    CloseCamera(false);
    return where + "the camera worker passed " + std::to_string(fds.size()) +
           " buffers, announced " + std::to_string(c.buffers);
  }
  for (size_t i = 0; i < fds.size(); ++i) {
    void* addr = mmap(nullptr, c.length[i], PROT_READ, MAP_SHARED, fds[i].get(), 0);
    if (addr == MAP_FAILED) {
      const std::string why = strerror(errno);
      CloseCamera(false);
      return where + "mmap of frame buffer " + std::to_string(i) + " failed: " + why;
    }
    mappings_.push_back({addr, c.length[i], c.offset[i]});
  }
  id_ = c.id;
  format_ = static_cast<PixelFormat>(c.format);
  width_ = c.width;
  height_ = c.height;
  stride_ = c.stride;
  recovery_.FrameArrived();  // The silence clock starts with the stream.
  std::lock_guard lock(describe_mutex_);
  description_ = "libcamera:" + id_ + " " + c.description + " -> " +
                 (options_.gray ? "GRAY8" : "BGR8") + " (worker pid " +
                 std::to_string(worker_.pid()) + ")";
  return {};
}

void LibcameraSource::CloseCamera(bool stop) {
  if (socket_.valid() && stop) {
    lcipc::Command c{MsgType::kStop, 0};
    lcipc::Send(socket_.get(), &c, sizeof(c));
  }
  worker_.Reap(stop ? std::chrono::milliseconds(2000) : std::chrono::milliseconds(0));
  socket_.reset();
  for (const Mapping& m : mappings_) munmap(m.addr, m.length);
  mappings_.clear();
}

void LibcameraSource::Close() {
  CloseCamera(true);
  opened_ = false;
  recovery_.Reset();
}

std::string LibcameraSource::Lose(const std::string& why) {
  // SIGKILL: stopping a camera whose device is gone aborts inside libcamera 0.0.3 anyway.
  CloseCamera(false);
  recovery_.Lose();
  std::lock_guard lock(describe_mutex_);
  description_ = "libcamera:" + Name() + " (lost: " + why + "; reopening)";
  return "libcamera " + Name() + ": camera lost (" + why + "); reopening with back-off";
}

ReadStatus LibcameraSource::Read(Frame* frame, std::chrono::milliseconds timeout,
                                 std::string* error) {
  const auto deadline = Clock::now() + timeout;
  if (!opened_) {
    if (error) *error = "libcamera " + options_.camera + ": Read() before Open()";
    return ReadStatus::kError;
  }
  if (recovery_.lost()) {
    if (!recovery_.AttemptDue(deadline)) return ReadStatus::kTimeout;
    if (const std::string e = OpenCamera(); !e.empty()) {
      recovery_.AttemptFailed();
      std::lock_guard lock(describe_mutex_);
      description_ = "libcamera:" + Name() + " (lost; reopen failed: " + e + ")";
      return ReadStatus::kTimeout;
    }
    recovery_.AttemptSucceeded();
  }
  WorkerMessage m{};
  const long n = ReceiveBefore(socket_.get(), deadline, &m, nullptr);
  std::string lost;
  if (n == -2) {
    if (!recovery_.Silent()) return ReadStatus::kTimeout;
    lost = "no frame for " + std::to_string(options_.lost_after_ms) + " ms";
  } else if (n <= 0) {
    lost = "camera worker " + worker_.Reap(std::chrono::milliseconds(500));
  } else if (m.type == MsgType::kDisconnected) {
    lost = "disconnected";
  } else if (m.type != MsgType::kFrame || m.frame.index >= mappings_.size()) {
    lost = "unexpected message from the camera worker";
  }
  if (!lost.empty()) {
    const std::string e = Lose(lost);
    if (error) *error = e;
    return ReadStatus::kError;
  }
  recovery_.FrameArrived();
  const lcipc::FrameReady& f = m.frame;
  const Mapping& map = mappings_[f.index];
  const auto* data = static_cast<const uint8_t*>(map.addr) + map.offset;
  std::string convert_error;
  if (f.ok) {
    // An MJPEG frame is bytesused long; a raw one fills the buffer from plane 0's offset.
    const size_t size = format_ == PixelFormat::kMjpeg ? f.bytesused : map.length - map.offset;
    convert_error = ConvertFrame(format_, data, size, width_, height_, stride_, options_.gray,
                                 &decoder_, &frame->image);
  }
  // The buffer goes back to the worker; a dead worker shows at the next Read.
  lcipc::Command requeue{MsgType::kRequeue, f.index};
  lcipc::Send(socket_.get(), &requeue, sizeof(requeue));
  if (!f.ok) return ReadStatus::kTimeout;
  if (!convert_error.empty()) {
    if (error) *error = "libcamera " + id_ + ": " + convert_error;
    return ReadStatus::kError;
  }
  frame->capture_time_ns = f.timestamp_ns ? static_cast<int64_t>(f.timestamp_ns) : MonotonicNowNs();
  frame->source_time_s = static_cast<double>(f.timestamp_ns) * 1e-9;
  frame->sequence = sequence_++;
  frame->source_id = id_;
  return ReadStatus::kFrame;
}

std::string LibcameraSource::Describe() const {
  std::lock_guard lock(describe_mutex_);
  return description_;
}

namespace {

std::unique_ptr<FrameSource> MakeLibcameraSource(const SourceUri& p, const std::string&) {
  if (p.target.empty()) {
    throw SourceUriError("camera URI '" + p.text + "': libcamera needs a camera id or index, e.g. libcamera:0");
  }
  LibcameraOptions o;
  o.camera = p.target;
  for (const auto& [key, value] : p.params) {
    if (key == "width") {
      o.width = UriNumber<int>(p, key, value, 1, 16384);
    } else if (key == "height") {
      o.height = UriNumber<int>(p, key, value, 1, 16384);
    } else if (key == "format") {
      o.format = ParsePixelFormat(value);
      if (!o.format) throw SourceUriError("camera URI '" + p.text + "': format=" + value + " is not supported");
    } else if (key == "gray") {
      o.gray = UriBool(p, key, value);
    } else if (key == "timeout_ms") {
      o.lost_after_ms = UriNumber<int>(p, key, value, 100, 600000);
    } else {
      throw SourceUriError("camera URI '" + p.text + "': unknown parameter '" + key +
                           "' (libcamera takes width, height, format, gray, timeout_ms)");
    }
  }
  if ((o.width == 0) != (o.height == 0)) {
    throw SourceUriError("camera URI '" + p.text + "': give both width and height");
  }
  return std::make_unique<LibcameraSource>(o);
}

}  // namespace

MM_REGISTER_FRAME_SOURCE(libcamera, MakeLibcameraSource);

}  // namespace mm
