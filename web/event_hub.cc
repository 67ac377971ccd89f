#include "web/event_hub.h"

#include <spdlog/spdlog.h>
#include <algorithm>
#include <nlohmann/json.hpp>

namespace mm {

using json = nlohmann::json;

std::optional<std::string> EventHub::Client::Next(std::chrono::milliseconds timeout, bool* closed) {
  std::unique_lock lock(mutex_);
  ready_.wait_for(lock, timeout, [this] { return closed_ || !queue_.empty(); });
  *closed = closed_;
  if (closed_ || queue_.empty()) return std::nullopt;
  std::string message = std::move(queue_.front());
  queue_.pop_front();
  return message;
}

EventHub::EventHub(DaemonLink& link, EventHubOptions options) : link_(link), options_(options) {}

EventHub::~EventHub() { Stop(); }

void EventHub::Start() {
  std::lock_guard lock(mutex_);
  if (relay_.joinable() || stopping_) return;
  relay_ = std::thread([this] { Relay(); });
}

void EventHub::Stop() {
  std::vector<std::shared_ptr<Client>> clients;
  {
    std::lock_guard lock(mutex_);
    stopping_ = true;
    clients.swap(clients_);
  }
  stop_cv_.notify_all();
  for (const auto& c : clients) {
    std::lock_guard lock(c->mutex_);
    c->closed_ = true;
    c->ready_.notify_all();
  }
  if (relay_.joinable()) relay_.join();
}

std::shared_ptr<EventHub::Client> EventHub::Subscribe() {
  std::lock_guard lock(mutex_);
  if (stopping_ || clients_.size() >= options_.max_clients) return nullptr;
  clients_.push_back(std::make_shared<Client>());
  return clients_.back();
}

void EventHub::Unsubscribe(const std::shared_ptr<Client>& client) {
  std::lock_guard lock(mutex_);
  std::erase(clients_, client);
}

void EventHub::Publish(const std::string& message) {
  std::vector<std::shared_ptr<Client>> clients;
  {
    std::lock_guard lock(mutex_);
    clients = clients_;
  }
  for (const auto& c : clients) {
    bool fell_behind = false;
    {
      std::lock_guard lock(c->mutex_);
      if (c->closed_) continue;
      if (c->queue_.size() >= options_.max_queued) {
        c->closed_ = true;  // Its stream ends; the browser reconnects and fetches the state.
        fell_behind = true;
      } else {
        c->queue_.push_back(message);
      }
      c->ready_.notify_all();
    }
    if (fell_behind) Unsubscribe(c);
  }
}

bool EventHub::connected() const {
  std::lock_guard lock(mutex_);
  return connected_;
}

std::string EventHub::EventMessage(const std::string& line) {
  const json event = json::parse(line, nullptr, /*allow_exceptions=*/false);
  if (!event.is_object()) return {};
  const auto name = event.find("event");
  if (name == event.end() || !name->is_string()) return {};
  const std::string& text = name->get_ref<const std::string&>();
  // An SSE field ends at a line break: a name holding one is no event name.
  if (text.empty() || text.find_first_of("\r\n") != std::string::npos) return {};
  std::string message;
  if (const auto seq = event.find("seq"); seq != event.end() && seq->is_number_unsigned()) {
    message += "id: " + std::to_string(seq->get<uint64_t>()) + "\n";
  }
  // dump() escapes control characters, so the data is one line.
  message += "event: " + text + "\ndata: " + event.dump() + "\n\n";
  return message;
}

std::string EventHub::StatusMessage(const std::string& status_json) {
  return "event: status\ndata: " + status_json + "\n\n";
}

void EventHub::Relay() {
  bool announced_gone = false;
  for (;;) {
    {
      std::lock_guard lock(mutex_);
      if (stopping_) return;
    }
    bool first = true;
    try {
      link_.Watch(
          [&](const std::string& line) {
            if (first) {
              // The subscription's reply carries the status at this moment.
              first = false;
              const json reply = json::parse(line, nullptr, /*allow_exceptions=*/false);
              {
                std::lock_guard lock(mutex_);
                connected_ = true;
              }
              announced_gone = false;
              spdlog::info("events: subscribed to the daemon");
              if (reply.is_object() && reply.contains("status")) {
                Publish(StatusMessage(reply["status"].dump()));
              }
              return;
            }
            if (const std::string message = EventMessage(line); !message.empty()) {
              Publish(message);
            }
          },
          [this] {
            std::lock_guard lock(mutex_);
            return !stopping_;
          });
    } catch (const std::exception& e) {
      if (!announced_gone) spdlog::warn("events: {}", e.what());
    }
    {
      std::lock_guard lock(mutex_);
      connected_ = false;
    }
    if (!announced_gone) {
      announced_gone = true;
      Publish(kDaemonGoneMessage);
    }
    std::unique_lock lock(mutex_);
    stop_cv_.wait_for(lock, options_.retry, [this] { return stopping_; });
  }
}

}  // namespace mm
