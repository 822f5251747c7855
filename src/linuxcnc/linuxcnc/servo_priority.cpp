// SPDX-License-Identifier: MIT
#include "linuxcnc/servo_priority.hpp"

#include "linuxcnc/namespace_processes.hpp"

#include <sched.h>

#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <set>
#include <string>

namespace lbpkit::linuxcnc {

namespace fs = std::filesystem;

ServoThreadPriority::ServoThreadPriority(unsigned long networkNamespace)
    : networkNamespace_(networkNamespace), thread_([this] { run(); }) {}

ServoThreadPriority::~ServoThreadPriority() {
  stop_ = true;
  thread_.join();
}

void ServoThreadPriority::run() {
  std::set<long> done;
  while (!stop_) {
    forEachProcessIn(networkNamespace_, [&](const fs::path& proc) {
      if (commandOf(proc) != "rtapi_app") return;
      const long pid = std::atol(proc.filename().c_str());
      std::error_code ec;
      for (const auto& t : fs::directory_iterator(proc / "task", ec)) {
        const long tid = std::atol(t.path().filename().c_str());
        if (done.count(tid) != 0) continue;
        // A new thread is "rtapi_app" until it names itself: the tasks and
        // the message thread are told apart once they have.
        const auto task = commandOf(t.path());
        sched_param sp{};
        int policy = SCHED_FIFO;
        if (task == "rtapi_app:mesg") {
          // Created by the main thread, it has the main thread's class if
          // that was raised first: back to the normal class.
          policy = SCHED_OTHER;
        } else if (tid == pid || task.rfind("rtapi_app:T", 0) == 0) {
          sp.sched_priority = kPriority;
        } else {
          continue;
        }
        if (::sched_setscheduler(static_cast<pid_t>(tid), policy, &sp) == 0) done.insert(tid);
      }
    });
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
}

}  // namespace lbpkit::linuxcnc
