// SPDX-License-Identifier: MIT
#include "linuxcnc/servo_priority.hpp"

#include <sched.h>
#include <sys/stat.h>

#include <cctype>
#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <set>
#include <string>

namespace lbpkit::linuxcnc {

namespace {
namespace fs = std::filesystem;

unsigned long networkNamespaceOf(const fs::path& proc) {
  struct stat st {};
  return ::stat((proc / "ns/net").c_str(), &st) == 0 ? static_cast<unsigned long>(st.st_ino) : 0;
}

std::string commandOf(const fs::path& proc) {
  std::ifstream comm(proc / "comm");
  std::string c;
  std::getline(comm, c);
  return c;
}
}  // namespace

ServoThreadPriority::ServoThreadPriority(unsigned long networkNamespace)
    : networkNamespace_(networkNamespace), thread_([this] { run(); }) {}

ServoThreadPriority::~ServoThreadPriority() {
  stop_ = true;
  thread_.join();
}

void ServoThreadPriority::run() {
  std::set<long> done;
  while (!stop_) {
    std::error_code ec;
    for (const auto& p : fs::directory_iterator("/proc", ec)) {
      const auto name = p.path().filename().string();
      if (name.empty() || std::isdigit(static_cast<unsigned char>(name[0])) == 0) continue;
      if (commandOf(p.path()) != "rtapi_app" || networkNamespaceOf(p.path()) != networkNamespace_) continue;
      const long pid = std::atol(name.c_str());
      for (const auto& t : fs::directory_iterator(p.path() / "task", ec)) {
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
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
}

}  // namespace lbpkit::linuxcnc
