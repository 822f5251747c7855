// SPDX-License-Identifier: MIT
// The process behind a host's datagrams, and whether it is running: what
// the sim's host clock asks when a host falls silent (docs/clocks.md). A
// servo thread that a kernel without real-time scheduling keeps waiting for
// its CPU is late, not stopped: it is runnable all the while. One that was
// stopped (SIGSTOP), killed or that simply stopped cycling is not.
//
// Both read /proc (proc(5)); neither is for a real-time path: they list
// folders and allocate.
#pragma once

#include <sys/types.h>

#include <cstdint>
#include <optional>

namespace lbpkit::process {

// The process (its thread group ID) holding the UDP socket whose local
// address is `address`:`port` (IPv4, the address in network byte order as
// in sockaddr_in, the port in host byte order), or else one bound to that
// port on any address, in any network namespace a process this one may
// look into is in: the socket's inode from that namespace's
// /proc/PID/net/udp, then the /proc/PID/fd link "socket:[INODE]" of the
// process that holds it. Empty when no such socket is listed or no process
// this one may look into (ptrace access, as for ls -l /proc/PID/fd) holds
// it; a set-user-ID program such as LinuxCNC's rtapi_app is visible to
// root only.
[[nodiscard]] std::optional<pid_t> udpSocketOwner(std::uint32_t address, std::uint16_t port);

// How the threads of a process stand, from the state letter of each
// /proc/PID/task/TID/stat.
enum class ThreadsState : std::uint8_t {
  Runnable,  // one at least is running or waiting for a CPU (R), or in an uninterruptible wait (D)
  Waiting,   // all sleep (S, I), perhaps in a wait of their own choosing
  Stopped,   // stopped by a signal or a tracer (T, t): no thread of it runs until continued
  Gone,      // no such process, or a zombie (Z, X)
};
[[nodiscard]] ThreadsState threadsState(pid_t pid);

}  // namespace lbpkit::process
