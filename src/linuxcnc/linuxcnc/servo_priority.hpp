// LinuxCNC's servo thread as a real-time kernel would run it: SCHED_FIFO.
//
// Debian's LinuxCNC (linuxcnc-uspace) runs rtapi_app's threads at the
// normal scheduling class when it cannot raise them itself (no
// RLIMIT_RTPRIO, rtapi_app as an unprivileged user): on a CPU it shares
// with the rest of LinuxCNC (the task, the display, halui) its servo thread
// is then late by tens of milliseconds now and then, and hm2_eth's reads,
// whose deadline counts from the period's start (LinuxCNC: hm2_eth.c),
// fail ("error finishing read"). This gives every thread of the rtapi_app
// in one network namespace (rtapi_app, rtapi_app:T#n) SCHED_FIFO from
// outside, as rtapi_app would on a real-time kernel, below `lbpkit sim`'s
// card thread (40) so that the card still answers first on a shared CPU.
// Only that namespace's rtapi_app: another LinuxCNC on the PC is not ours.
// Needs root (CAP_SYS_NICE).
#pragma once

#include <atomic>
#include <thread>

namespace lbpkit::linuxcnc {

class ServoThreadPriority {
 public:
  static constexpr int kPriority = 30;
  // Looks for the namespace's rtapi_app threads every 5 ms until destroyed:
  // LinuxCNC starts them as it loads its HAL files.
  explicit ServoThreadPriority(unsigned long networkNamespace);
  ~ServoThreadPriority();
  ServoThreadPriority(const ServoThreadPriority&) = delete;
  ServoThreadPriority& operator=(const ServoThreadPriority&) = delete;

 private:
  void run();
  unsigned long networkNamespace_;
  std::atomic<bool> stop_{false};
  std::thread thread_;
};

}  // namespace lbpkit::linuxcnc
