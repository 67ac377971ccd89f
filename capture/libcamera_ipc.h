#pragma once
// The messages between LibcameraSource and its camera worker (capture/libcamera_worker.cc).
//
// libcamera 0.0.3 (Debian 12) cannot survive a camera that goes away and comes back: its udev
// enumerator crashes on the re-add, the camera's `disconnected` signal may never come, and
// stopping a camera whose device is gone aborts (docs/capture.md). So libcamera runs in a child
// process, as libcamera itself isolates its IPA modules: a crash there is a lost camera, not a
// dead daemon. The worker sends the frame buffers' dmabuf fds once (SCM_RIGHTS); the parent maps
// them and reads each completed frame in place, then hands the buffer back. No pixel is copied.
//
// Transport: an AF_UNIX SOCK_SEQPACKET pair (message boundaries kept, EOF when a side dies).
// Messages are fixed-size PODs starting with their MsgType.

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "base/unique_fd.h"

namespace mm::lcipc {

/// The worker finds its socket here (posix_spawn dup2s the parent's end onto it).
inline constexpr int kSocketFd = 3;
inline constexpr uint32_t kMaxBuffers = 16;

enum class MsgType : uint32_t {
  // Worker -> parent.
  kConfigured = 1,    ///< Configured + one dmabuf fd per buffer; frames follow.
  kError = 2,         ///< Text: why the worker could not list / open; it exits next.
  kFrame = 3,         ///< FrameReady: a buffer holds a frame until the parent requeues it.
  kDisconnected = 4,  ///< libcamera signalled the camera's removal; the worker exits next.
  kCameras = 5,       ///< Text: camera ids, one per line (the answer to --list).
  // Parent -> worker.
  kRequeue = 10,  ///< Command: the parent is done with buffer `index`.
  kStop = 11,     ///< Command: stop streaming, release the camera and exit.
};

struct Configured {
  MsgType type = MsgType::kConfigured;
  int32_t format = 0;  ///< mm::PixelFormat.
  int32_t width = 0, height = 0;
  uint32_t stride = 0;
  uint32_t buffers = 0;
  uint64_t offset[kMaxBuffers] = {};  ///< Offset of plane 0 in each dmabuf.
  uint64_t length[kMaxBuffers] = {};  ///< Bytes to map from each dmabuf (all planes).
  char id[256] = {};
  char description[256] = {};
};

struct FrameReady {
  MsgType type = MsgType::kFrame;
  uint32_t index = 0;      ///< Buffer index (as in Configured).
  uint32_t ok = 0;         ///< FrameMetadata::FrameSuccess.
  uint64_t bytesused = 0;  ///< Sum over planes.
  uint64_t timestamp_ns = 0;
};

struct Command {
  MsgType type = MsgType::kStop;
  uint32_t index = 0;
};

struct Text {
  MsgType type = MsgType::kError;
  char text[4000] = {};
};

/// Copies `s` into a fixed field, truncated, always NUL-terminated.
template <size_t N>
void SetText(char (&field)[N], const std::string& s) {
  const size_t n = s.size() < N - 1 ? s.size() : N - 1;
  s.copy(field, n);
  field[n] = '\0';
}

/// Sends one message with optional fds. Returns false (errno set) when the peer is gone.
bool Send(int socket, const void* data, size_t size, const std::vector<int>& fds = {});

/// Receives one message (up to `size` bytes) and the fds it carries. Returns the message's
/// size, 0 at EOF (the peer closed or died), -1 on error (errno set).
long Receive(int socket, void* data, size_t size, std::vector<UniqueFd>* fds = nullptr);

}  // namespace mm::lcipc
