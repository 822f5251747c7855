// SPDX-License-Identifier: MIT
#include "linuxcnc_host.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <sys/utsname.h>
#include <unistd.h>

#include <fmt/core.h>

#include <algorithm>
#include <cctype>
#include <cstdlib>
#include <fstream>
#include <sstream>

#include "process/process.hpp"
#include "linuxcnc_run.hpp"

// The layers' namespaces this file names (docs/architecture.md).
namespace app = lbpkit::app;

namespace lbpkit::app::linuxcnc_host {

namespace fs = std::filesystem;

namespace {
bool containsNoCase(std::string text, std::string word) {
  auto lower = [](std::string s) {
    std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
    return s;
  };
  return lower(std::move(text)).find(lower(std::move(word))) != std::string::npos;
}
}  // namespace

RealTime detectRealTime() {
  if (const char* said = std::getenv("LBPKIT_REALTIME"); said != nullptr && *said != '\0') {
    const std::string s = said;
    if (s == "yes") return {true, "LBPKIT_REALTIME=yes"};
    if (s == "no") return {false, "LBPKIT_REALTIME=no"};
  }
  utsname u{};
  ::uname(&u);
  std::string kernel;
  if (containsNoCase(u.version, "PREEMPT_RT") || containsNoCase(u.version, "PREEMPT RT")) {
    kernel = "PREEMPT_RT kernel";
  } else {
    std::ifstream flag("/sys/kernel/realtime");
    int value = 0;
    if (flag >> value && value == 1) kernel = "real-time kernel (/sys/kernel/realtime)";
    else if (fs::exists("/proc/xenomai")) kernel = "Xenomai kernel";
    else if (fs::exists("/proc/rtai")) kernel = "RTAI kernel";
  }
  if (kernel.empty()) return {false, fmt::format("the kernel ({}) is not real-time (no PREEMPT_RT)", u.release)};
  const auto rtapi = lbpkit::process::systemProgram("rtapi_app");
  struct stat st {};
  if (!rtapi || ::stat(rtapi->c_str(), &st) != 0 || st.st_uid != 0 || (st.st_mode & S_ISUID) == 0)
    return {false, kernel + ", but rtapi_app is not setuid root"};
  return {true, kernel + ", rtapi_app setuid root"};
}

long servoPeriodForClock(const std::string& text) {
  try {
    std::size_t used = 0;
    const long ns = std::stol(text, &used);
    if (used == text.size() && ns >= 100'000 && ns <= 10'000'000) return ns;
  } catch (const std::exception&) {
  }
  return 0;
}

std::string lateServoHal(const std::vector<std::string>& boards) {
  std::string text =
      "# Written by lbpkit linuxcnc for a PC whose kernel is not real-time: LinuxCNC's servo\n"
      "# thread runs late now and then, and hm2_eth's own wait for a reply (80 % of a servo\n"
      "# period, on the wall clock) then ends before it looks for the reply the card sent in\n"
      "# time. It waits as long as an on-time servo thread would find the reply there,\n"
      "# and the card's watchdog takes a servo thread held back for a while for the live\n"
      "# one it is (docs/linuxcnc.md#on-a-pc-without-a-real-time-kernel).\n";
  for (const auto& board : boards)
    text += fmt::format("setp {}.packet-read-timeout {}\nsetp {}.watchdog.timeout_ns {}\n", board,
                        kPacketReadTimeoutNs, board, kHostMot2WatchdogNs);
  return text;
}

std::string withLastHalFile(const std::string& ini, const std::string& halFile) {
  std::istringstream in(ini);
  std::vector<std::string> lines;
  for (std::string line; std::getline(in, line);) lines.push_back(line);
  const std::string entry = "HALFILE = " + halFile;
  bool inHal = false;
  std::ptrdiff_t last = -1, halSection = -1;
  for (std::size_t i = 0; i < lines.size(); ++i) {
    const auto first = lines[i].find_first_not_of(" \t");
    if (first == std::string::npos) continue;
    if (lines[i][first] == '[') {
      inHal = lines[i].compare(first, 5, "[HAL]") == 0;
      if (inHal) halSection = static_cast<std::ptrdiff_t>(i);
      continue;
    }
    if (inHal && lines[i].compare(first, 7, "HALFILE") == 0 && lines[i].find('=') != std::string::npos &&
        lines[i].find_first_not_of(" \t", first + 7) == lines[i].find('='))
      last = static_cast<std::ptrdiff_t>(i);
  }
  if (last >= 0) lines.insert(lines.begin() + last + 1, entry);
  else if (halSection >= 0) lines.insert(lines.begin() + halSection + 1, entry);
  else lines.insert(lines.end(), {"", "[HAL]", entry});
  std::string out;
  for (const auto& l : lines) out += l + "\n";
  return out;
}

LinuxCncLog::~LinuxCncLog() {
  for (auto& [name, f] : files_)
    if (f.fd >= 0) ::close(f.fd);
}

void LinuxCncLog::poll() {
  std::error_code ec;
  for (const auto& e : fs::directory_iterator(tmp_, ec)) {
    const auto name = e.path().filename().string();
    const bool print = name.rfind("linuxcnc.print.", 0) == 0;
    if ((!print && name.rfind("linuxcnc.debug.", 0) != 0) || files_.count(name) != 0 || files_.size() >= 16) continue;
    struct stat st {};
    const int fd = linuxcnc_run::openUsersFile(e.path(), user_, st);
    if (fd >= 0) files_[name] = File{fd, print ? "print" : "debug", 0, {}, {}};
  }
  for (auto& [name, f] : files_) {
    // What the file gained, at most 1 MiB a look (a file that grows faster
    // is read on at the next): nothing is read, or allocated, when it did
    // not grow.
    struct stat st {};
    if (::fstat(f.fd, &st) != 0 || st.st_size <= f.read) continue;
    std::string chunk(static_cast<std::size_t>(std::min<off_t>(st.st_size - f.read, 1 << 20)), '\0');
    const auto n = ::pread(f.fd, chunk.data(), chunk.size(), f.read);
    if (n <= 0) continue;
    f.read += n;
    f.partial.append(chunk.data(), static_cast<std::size_t>(n));
    for (std::size_t nl; (nl = f.partial.find('\n')) != std::string::npos;) {
      // hostmot2's list of the card's pins (hundreds of lines at every
      // start) is a report, not a message: it would push LinuxCNC's words
      // out of the lines kept.
      if (f.partial.compare(0, 4, "hm2/") == 0 && f.partial.substr(0, nl).find(" IO Pin ") != std::string::npos) {
        f.partial.erase(0, nl + 1);
        continue;
      }
      f.last.push_back(f.partial.substr(0, std::min<std::size_t>(nl, 400)));
      f.partial.erase(0, nl + 1);
      if (f.last.size() > 200) f.last.pop_front();
    }
  }
}

void LinuxCncLog::printEnd(std::size_t lines, const std::string& kind) const {
  for (const auto& [name, f] : files_) {
    if (f.kind != kind || f.last.empty()) continue;
    fmt::print("lbpkit linuxcnc: what LinuxCNC printed ({}, its {} file){}:\n", name,
               f.kind == "print" ? "standard output's" : "standard error's",
               f.last.size() > lines ? fmt::format(", the last {} lines", lines) : std::string());
    for (std::size_t i = f.last.size() > lines ? f.last.size() - lines : 0; i < f.last.size(); ++i)
      fmt::print("  | {}\n", f.last[i]);
  }
}

}  // namespace lbpkit::app::linuxcnc_host
