#pragma once
// EventHub: the daemon's event stream, relayed to any number of Server-Sent-Event clients
// (docs/web.md). One thread holds one `watch` subscription to the daemon (DaemonLink::Watch)
// and reconnects every `retry` while the daemon is away; each client has its own bounded queue,
// so a client that stops reading loses its stream (it is closed and the browser's EventSource
// reconnects) and never holds the relay back.
//
// Messages are ready to send: "id: SEQ\nevent: NAME\ndata: JSON\n\n" for a daemon event,
// "event: status\ndata: STATUS\n\n" when a subscription (re)starts, and
// "event: daemon\ndata: {\"connected\":false}\n\n" when the daemon went away.
//
// Thread-safety: thread-safe.

#include <chrono>
#include <condition_variable>
#include <cstddef>
#include <deque>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "web/daemon_link.h"

namespace mm {

struct EventHubOptions {
  size_t max_clients = 8;                 ///< More are refused (each holds an HTTP thread).
  size_t max_queued = 256;                ///< A client with more messages waiting is closed.
  std::chrono::milliseconds retry{1000};  ///< Between attempts to reach the daemon.
};

class EventHub {
 public:
  /// One client's queue. Next() waits for its next message.
  class Client {
   public:
    /// The next message, or nullopt after `timeout` without one; `*closed` says the stream
    /// ended (the hub stopped, or this client fell `max_queued` behind).
    std::optional<std::string> Next(std::chrono::milliseconds timeout, bool* closed);

   private:
    friend class EventHub;
    std::mutex mutex_;
    std::condition_variable ready_;
    std::deque<std::string> queue_;
    bool closed_ = false;
  };

  EventHub(DaemonLink& link, EventHubOptions options);
  ~EventHub();
  EventHub(const EventHub&) = delete;
  EventHub& operator=(const EventHub&) = delete;

  /// Starts the relay thread.
  void Start();
  /// Ends every client's stream and stops the relay thread (idempotent).
  void Stop();

  /// A new client, or nullptr when `max_clients` are connected (or the hub stopped).
  std::shared_ptr<Client> Subscribe();
  /// Forgets a client (its stream ended).
  void Unsubscribe(const std::shared_ptr<Client>& client);

  /// Queues `message` to every client (the relay calls it; tests may too).
  void Publish(const std::string& message);

  /// Whether the relay holds a subscription to the daemon now.
  [[nodiscard]] bool connected() const;

  /// The SSE message for one of the daemon's event lines, or "" when it is not an event.
  static std::string EventMessage(const std::string& line);
  /// The SSE message of the daemon's status (one line of JSON).
  static std::string StatusMessage(const std::string& status_json);
  /// The SSE message saying the daemon went away.
  static constexpr const char* kDaemonGoneMessage = "event: daemon\ndata: {\"connected\":false}\n\n";

 private:
  void Relay();

  DaemonLink& link_;
  const EventHubOptions options_;
  mutable std::mutex mutex_;
  std::condition_variable stop_cv_;
  std::vector<std::shared_ptr<Client>> clients_;
  bool stopping_ = false;
  bool connected_ = false;
  std::thread relay_;
};

}  // namespace mm
