// SPDX-License-Identifier: MIT
#include "daemon/drain_thread.hpp"

#include <utility>

namespace lbpkit::server {

DrainThread::DrainThread(std::chrono::milliseconds period, std::function<void()> drain)
    : period_(period), drain_(std::move(drain)) {
  thread_ = std::thread([this] { run(); });
}

DrainThread::~DrainThread() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stopping_ = true;
  }
  wake_.notify_all();
  thread_.join();
  drain_();
}

void DrainThread::run() {
  std::unique_lock<std::mutex> lock(mutex_);
  while (!stopping_) {
    wake_.wait_for(lock, period_, [this] { return stopping_; });
    lock.unlock();
    drain_();
    lock.lock();
  }
}

}  // namespace lbpkit::server
