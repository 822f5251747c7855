// SPDX-License-Identifier: MIT
// The PC `lbpkit linuxcnc` runs LinuxCNC on, as LinuxCNC sees it: whether
// its servo thread will run real-time (docs/linuxcnc.md#on-a-pc-without-a-real-time-kernel),
// what a configuration needs where it will not, and what LinuxCNC said.
#pragma once

#include <sys/types.h>

#include <deque>
#include <filesystem>
#include <map>
#include <string>
#include <vector>

namespace lbpkit::app::linuxcnc_host {

// Whether LinuxCNC's uspace rtapi_app runs its threads real-time here, as
// it decides itself (LinuxCNC: rtapi_is(3)): a kernel that says it is
// real-time (PREEMPT_RT in its version, /sys/kernel/realtime, Xenomai or
// RTAI) and an rtapi_app that is setuid root. LBPKIT_REALTIME=yes|no in the
// environment decides instead (a kernel lbpkit does not recognise; the
// tests).
struct RealTime {
  bool yes = false;
  std::string why;  // "the kernel is not PREEMPT_RT", "PREEMPT_RT kernel, rtapi_app setuid root"
};
RealTime detectRealTime();

// A servo period from the INI's [EMCMOT]SERVO_PERIOD (nanoseconds) that
// `lbpkit sim --clock host=PERIOD` takes (100 us to 10 ms), or 0.
long servoPeriodForClock(const std::string& text);

// The HAL file a configuration's copy gets, after its own HAL files, where
// its servo thread runs late now and then, on each hm2_eth board: hm2_eth
// waits for a reply as an on-time servo thread would find it
// (packet-read-timeout), and the HostMot2 watchdog takes a servo thread
// held back for a while for the live one it is (watchdog.timeout_ns). A
// LinuxCNC that stopped is still found at once by the 7I77's own 50 ms
// watchdog, which turns the field outputs and drives off.
// `boards`: the hm2_eth boards' HAL names in the copy.
inline constexpr const char* kLateServoHalFile = "lbpkit-late-servo.hal";
inline constexpr long kPacketReadTimeoutNs = 20'000'000;    // under the host clock's 40 ms silence (docs/clocks.md)
inline constexpr long kHostMot2WatchdogNs = 500'000'000;    // past the longest stall of a servo thread seen here
std::string lateServoHal(const std::vector<std::string>& boards);
// `ini`'s text with `halFile` as its last [HAL]HALFILE (a [HAL] section
// added when it has none).
std::string withLastHalFile(const std::string& ini, const std::string& halFile);

// What LinuxCNC prints while it runs without a terminal: the linuxcnc
// script sends its standard output and error to /tmp/linuxcnc.print.* and
// /tmp/linuxcnc.debug.* (LinuxCNC: scripts/linuxcnc), in the run's own
// /tmp, and removes them when it ends. Read as they grow, by root, without
// trusting them (O_NOFOLLOW, regular files of LinuxCNC's user), and kept
// open once found, so that what LinuxCNC wrote last is read even after the
// script removed them: what LinuxCNC said is there to print when it stops
// or refuses.
class LinuxCncLog {
 public:
  LinuxCncLog(std::filesystem::path tmp, uid_t user) : tmp_(std::move(tmp)), user_(user) {}
  ~LinuxCncLog();
  LinuxCncLog(const LinuxCncLog&) = delete;
  LinuxCncLog& operator=(const LinuxCncLog&) = delete;
  // Reads what the files gained since the last look.
  void poll();
  // The last `lines` lines of each file of `kind` ("print": standard
  // output, "debug": standard error) read so far.
  void printEnd(std::size_t lines, const std::string& kind) const;

 private:
  struct File {
    int fd = -1;
    std::string kind;  // "print" or "debug"
    off_t read = 0;
    std::string partial;
    std::deque<std::string> last;
  };
  std::filesystem::path tmp_;
  uid_t user_;
  std::map<std::string, File> files_;
};

}  // namespace lbpkit::app::linuxcnc_host
