// SPDX-License-Identifier: MIT
// Where LinuxCNC runs against a card on this PC: a network namespace of its
// own, joined to the root namespace (where `lbpkit sim` answers) by veth
// pairs. Debian 12's hm2_eth cannot use a board on loopback, and a
// namespace keeps LinuxCNC's addresses and processes apart from the PC's.
// `lbpkit bench` and the tests that run LinuxCNC's own programs use it;
// it needs root (ip netns, ip link).
#pragma once

#include <optional>
#include <string>
#include <vector>

namespace lbpkit::linuxcnc {

// One veth pair: `name` in the root namespace, `name` + "h" inside.
struct VethLink {
  std::string name;             // at most 14 characters (IFNAMSIZ less the "h")
  std::string outsideAddress;   // "10.211.7.1/24": the sim's side
  std::string insideAddress;    // "10.211.7.2/24": LinuxCNC's side
  // A host route on the outside for an address inside, from the outside
  // address: for an outside /32 (the card at 10.10.10.10, as a
  // configuration's INI has it, reaching 10.10.10.2 inside).
  std::optional<std::string> routeTo;
};

// Held while a run chooses its addresses and claims them (the card's /32,
// LinuxCNC's address beside it, their routes and links): two runs started
// at once would otherwise both find the same address free, and the second's
// `ip route add` fail ("File exists"). An exclusive flock on `lockFile`
// (root's /run by default: no user can plant it), taken by the constructor
// (waiting for another run's) and released by the destructor. Throws
// lbpkit::Error naming the file when it is not root's own regular file or
// cannot be locked.
class AddressClaim {
 public:
  static constexpr const char* kLockFile = "/run/lbpkit-linuxcnc.lock";
  explicit AddressClaim(const std::string& lockFile = kLockFile);
  ~AddressClaim();
  AddressClaim(const AddressClaim&) = delete;
  AddressClaim& operator=(const AddressClaim&) = delete;

 private:
  int fd_ = -1;
};

class NetworkNamespace {
 public:
  // Makes namespace `name` with its loopback up and `links`; throws
  // lbpkit::Error naming the command that failed and what it said, after
  // removing what it had made.
  NetworkNamespace(std::string name, std::vector<VethLink> links);
  ~NetworkNamespace();
  NetworkNamespace(const NetworkNamespace&) = delete;
  NetworkNamespace& operator=(const NetworkNamespace&) = delete;

  // The links and the namespace go (what LinuxCNC still runs in it is the
  // caller's to stop first). Also done by the destructor.
  void remove();
  // Nothing of it is left: no namespace, no link.
  [[nodiscard]] bool gone() const;
  [[nodiscard]] const std::string& name() const { return name_; }
  // "ip netns exec NAME ": what runs a command inside, as a prefix for a
  // test's own shell command line. A program lbpkit runs uses execArgv().
  [[nodiscard]] std::string exec() const { return "ip netns exec " + name_ + " "; }
  // {"ip", "netns", "exec", NAME}: what runs a program inside, by an argument
  // vector (process/process.hpp). `ip` looks a bare program name up in its
  // PATH: what follows it is an absolute path (systemProgram), as lbpkit
  // finds every program it runs (docs/linuxcnc.md#what-runs-as-root).
  [[nodiscard]] std::vector<std::string> execArgv() const { return {"ip", "netns", "exec", name_}; }
  // The namespace's inode: what /proc/PID/ns/net of a process inside shows.
  [[nodiscard]] unsigned long inode() const;

 private:
  std::string name_;
  std::vector<VethLink> links_;
};

// The environment LinuxCNC's HAL commands run with inside: rtapi_app as the
// unprivileged `nobody` (RTAPI_UID, as Debian's LinuxCNC runs it for root)
// with its socket at `fifo` (RTAPI_FIFO_PATH), so that two LinuxCNCs on one
// PC do not meet. "env RTAPI_UID=65534 RTAPI_FIFO_PATH=... ": a prefix for a
// test's own shell command line; a program lbpkit runs uses rtapiSettings().
[[nodiscard]] std::string rtapiEnvironment(const std::string& fifo);
// The same environment as env(1)'s arguments, for an argument vector:
// {"RTAPI_UID=65534", "RTAPI_FIFO_PATH=" + fifo}.
[[nodiscard]] std::vector<std::string> rtapiSettings(const std::string& fifo);

}  // namespace lbpkit::linuxcnc
