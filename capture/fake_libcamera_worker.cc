// A stand-in for mm-libcamera-worker in unit tests of LibcameraSource's process logic (spawn,
// buffer passing, requeue, loss when the worker dies, respawn). It speaks the same protocol
// (capture/libcamera_ipc.h) with memfd buffers of a 64x48 YUYV test pattern whose luma is the
// frame count. The real worker is tested against vimc in the kernel stage.
//
//   fake_libcamera_worker --camera fake|crash-after-N|fail [--width W --height H]

#include <sys/mman.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <csignal>
#include <cstdlib>
#include <cstring>
#include <string>
#include <thread>
#include <vector>

#include "capture/frame.h"
#include "capture/libcamera_ipc.h"
#include "capture/pixel_format.h"

int main(int argc, char** argv) {
  namespace ipc = mm::lcipc;
  std::string camera;
  for (int i = 1; i + 1 < argc; i += 2) {
    if (std::string(argv[i]) == "--camera") camera = argv[i + 1];
  }
  if (camera == "fail") {
    ipc::Text t;
    ipc::SetText(t.text, "no such camera (fake)");
    ipc::Send(ipc::kSocketFd, &t, sizeof(t));
    return 1;
  }
  const int crash_after =
      camera.rfind("crash-after-", 0) == 0 ? std::atoi(camera.c_str() + 12) : -1;
  constexpr int kWidth = 64, kHeight = 48, kBuffers = 4;
  constexpr size_t kBytes = kWidth * kHeight * 2;
  ipc::Configured c;
  c.format = static_cast<int32_t>(mm::PixelFormat::kYuyv);
  c.width = kWidth;
  c.height = kHeight;
  c.stride = kWidth * 2;
  c.buffers = kBuffers;
  ipc::SetText(c.id, "fake:" + camera);
  ipc::SetText(c.description, "64x48-YUYV");
  std::vector<mm::UniqueFd> fds;
  std::vector<uint8_t*> maps;
  std::vector<int> raw;
  for (int i = 0; i < kBuffers; ++i) {
    fds.emplace_back(memfd_create("fake-frame", MFD_CLOEXEC));
    if (ftruncate(fds.back().get(), kBytes) != 0) return 1;
    maps.push_back(static_cast<uint8_t*>(
        mmap(nullptr, kBytes, PROT_READ | PROT_WRITE, MAP_SHARED, fds.back().get(), 0)));
    c.length[i] = kBytes;
    raw.push_back(fds.back().get());
  }
  if (!ipc::Send(ipc::kSocketFd, &c, sizeof(c), raw)) return 1;
  std::vector<bool> free(kBuffers, true);
  for (int frame = 0;; ++frame) {
    if (frame == crash_after) std::abort();
    // Take back the buffers the parent returned; block only while it holds all of them.
    for (;;) {
      const bool any_free = std::find(free.begin(), free.end(), true) != free.end();
      ipc::Command cmd;
      const long n = any_free ? recv(ipc::kSocketFd, &cmd, sizeof(cmd), MSG_DONTWAIT)
                              : ipc::Receive(ipc::kSocketFd, &cmd, sizeof(cmd));
      if (n < 0 && any_free && (errno == EAGAIN || errno == EWOULDBLOCK)) break;
      if (n <= 0 || cmd.type == ipc::MsgType::kStop) return 0;  // The parent is done or gone.
      if (cmd.type == ipc::MsgType::kRequeue && cmd.index < kBuffers) free[cmd.index] = true;
    }
    const auto index =
        static_cast<uint32_t>(std::find(free.begin(), free.end(), true) - free.begin());
    free[index] = false;
    for (size_t p = 0; p < kBytes; p += 2) {
      maps[index][p] = static_cast<uint8_t>(frame);  // Y
      maps[index][p + 1] = 128;                      // U / V
    }
    ipc::FrameReady r;
    r.index = index;
    r.ok = 1;
    r.bytesused = kBytes;
    r.timestamp_ns = static_cast<uint64_t>(mm::MonotonicNowNs());
    if (!ipc::Send(ipc::kSocketFd, &r, sizeof(r))) return 0;
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
}
