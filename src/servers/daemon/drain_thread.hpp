// SPDX-License-Identifier: MIT
// A thread of its own that empties a ring filled on the card thread: it
// calls `drain` a few times a second, and once more when it stops, so the
// card thread only ever copies into preallocated memory and never waits on
// a file. Shared by the machine's CSV trace (trace_file.hpp) and the packet
// capture (pcap_recorder.hpp).
#pragma once

#include <chrono>
#include <condition_variable>
#include <functional>
#include <mutex>
#include <thread>

namespace lbpkit::server {

class DrainThread {
 public:
  // Starts the thread: `drain` runs every `period` on it.
  DrainThread(std::chrono::milliseconds period, std::function<void()> drain);
  // Stops and joins the thread, then drains what is left (the last moments).
  ~DrainThread();
  DrainThread(const DrainThread&) = delete;
  DrainThread& operator=(const DrainThread&) = delete;

 private:
  void run();

  std::chrono::milliseconds period_;
  std::function<void()> drain_;
  std::mutex mutex_;
  std::condition_variable wake_;
  bool stopping_ = false;
  std::thread thread_;
};

}  // namespace lbpkit::server
