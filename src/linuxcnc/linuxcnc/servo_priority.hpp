// SPDX-License-Identifier: MIT
// LinuxCNC's servo thread as a real-time kernel would run it: SCHED_FIFO.
//
// Debian's LinuxCNC (linuxcnc-uspace) runs rtapi_app's threads at the
// normal scheduling class when it cannot raise them itself (no
// RLIMIT_RTPRIO, rtapi_app as an unprivileged user): on a CPU it shares
// with the rest of LinuxCNC (the task, the display, halui) its servo thread
// is then late by tens of milliseconds now and then, and hm2_eth's reads,
// whose deadline counts from the period's start (LinuxCNC: hm2_eth.c),
// fail ("error finishing read"). This gives the rtapi_app in one network
// namespace SCHED_FIFO from outside, as rtapi_app would on a real-time
// kernel to its real-time tasks (the threads it names rtapi_app:T#n), and
// to its main thread, where a driver's set-up runs (hm2_eth's discovery,
// whose reads have deadlines of their own), below `lbpkit sim`'s card
// thread (40) so that the card still answers first on a shared CPU. Its
// message thread (rtapi_app:mesg, which prints what the real-time code
// queued, with calls that are not real-time safe: LinuxCNC,
// uspace_rtapi_app.cc) is at the normal class, where LinuxCNC creates it
// (it would inherit the main thread's class if created after the raise).
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
