#include "lbpkit/faults.hpp"

#include <array>
#include <string_view>

#include "remote/remote_device.hpp"

namespace lbpkit {

namespace {
std::string bits(std::uint8_t v, const std::array<std::string_view, 8>& names) {
  std::string s;
  for (unsigned b = 0; b < 8; ++b) {
    if (!((static_cast<unsigned>(v) >> b) & 1U) || names[b].empty()) continue;
    if (!s.empty()) s += ' ';
    s += names[b];
  }
  return s;
}
}  // namespace

std::string describeLocalFaults(std::uint8_t v) {
  return bits(v, {"CRCError", "InvalidCookieError", "OverrunError", "TimeoutError", "ExtraCharacterError",
                  "SerialBreakError", "RemoteFault", "TooManyErrors"});
}
std::string describeStatus(std::uint8_t v) {
  return bits(v, {"RemoteFault", "", "", "", "", "CommunicationError", "NoRemoteID", "CommunicationNotReady"});
}
std::string describeRemoteFaults(std::uint8_t v) { return bits(v, remote::fault::kNames); }
std::string describeLbpStatus(std::uint8_t v) {
  return bits(v, {"CRCError", "", "", "WatchdogTimeoutError", "BufferOverflowError", "InvalidWriteError",
                  "CommandTimeoutError", ""});
}

std::string describeCs(std::uint32_t cs) {
  std::string s;
  auto add = [&](const std::string& part) {
    if (part.empty()) return;
    if (!s.empty()) s += ' ';
    s += part;
  };
  add(describeLocalFaults(static_cast<std::uint8_t>(cs)));
  add(describeStatus(static_cast<std::uint8_t>(cs >> 8)));
  add(describeRemoteFaults(static_cast<std::uint8_t>(cs >> 24)));
  return s.empty() ? "ok" : s;
}

}  // namespace lbpkit
