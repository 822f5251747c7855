// SPDX-License-Identifier: MIT
#include "common.hpp"

#include <sched.h>
#include <sys/eventfd.h>
#include <unistd.h>

#include <fmt/core.h>

#include <csignal>
#include <cstdint>
#include <cstdlib>
#include <filesystem>

#include "lbpkit/error.hpp"
#include "lbpkit/lbp16_transport.hpp"
#include "process/process.hpp"
#include "sim_card/sim_transport.hpp"

// The layers' namespaces this file names (docs/architecture.md).
namespace hm2 = lbpkit::model::hm2;
namespace remote = lbpkit::model::remote;

namespace lbpkit::app {

std::atomic<bool> gStop{false};
namespace {
int gStopFd = -1;
extern "C" void onSignal(int) {
  gStop.store(true);
  // write(2) is async-signal-safe: a thread asleep on this descriptor wakes.
  const std::uint64_t one = 1;
  if (gStopFd >= 0) (void)!::write(gStopFd, &one, sizeof one);
}
}  // namespace

int stopFd() { return gStopFd; }

void installSignalHandlers() {
  if (gStopFd < 0) gStopFd = ::eventfd(0, EFD_NONBLOCK | EFD_CLOEXEC);
  struct sigaction sa{};
  sa.sa_handler = onSignal;
  sigemptyset(&sa.sa_mask);
  sigaction(SIGINT, &sa, nullptr);
  sigaction(SIGTERM, &sa, nullptr);
}

std::filesystem::path defaultStateDir() {
  if (const char* s = std::getenv("XDG_STATE_HOME"); s && *s) return std::filesystem::path(s) / "lbpkit";
  if (const char* h = std::getenv("HOME"); h && *h) return std::filesystem::path(h) / ".local/state/lbpkit";
  return std::filesystem::current_path() / ".lbpkit-state";
}

void CardOptions::add(CLI::App& cmd) {
  cmd.add_flag("--sim", sim, "Use the in-process virtual 7I92 with a 7I77 (the default when no card is named)");
  cmd.add_option("--addr", addr, "IP address of an Ethernet card (LBP16 on UDP port 27181; ADDR:PORT for another port)");
  cmd.add_option("--state", state, "EEPROM file for the virtual 7I77's field I/O processor (with --sim)");
  cmd.add_option("--modes", modes,
                 "Smart-serial channel modes, one character per channel from 0: a mode digit, or x to skip "
                 "the channel; channels past the string run in mode 0 (as LinuxCNC's sserial_port_0), "
                 "e.g. 3 for field I/O mode 3, 00x for the first 7I77 without its TB6 port");
  cmd.add_flag("--sinking", sinking, "With --sim: the virtual board is a 7I77D (sinking outputs)");
}

lbpkit::SmartSerial::Options CardOptions::serialOptions() const {
  lbpkit::SmartSerial::Options o;
  o.channelMask = 0xFF;
  if (modes.size() > 8) throw lbpkit::Error("--modes: an SSLBP port has at most 8 channels");
  for (std::size_t ch = 0; ch < modes.size(); ++ch) {
    const char c = modes[ch];
    if (c == 'x' || c == 'X') {
      o.channelMask = static_cast<std::uint8_t>(o.channelMask & ~(1U << ch));
      continue;
    }
    if (c < '0' || c > '9') throw lbpkit::Error(fmt::format("--modes: '{}' is neither a mode digit nor x", c));
    o.modes[ch] = static_cast<std::uint8_t>(c - '0');
  }
  return o;
}

Card openCard(const CardOptions& o) {
  Card c;
  if (!o.addr.empty() && o.sim) throw lbpkit::Error("--sim and --addr name two different cards: give one");
  if (!o.addr.empty()) {
    std::string host = o.addr;
    std::uint16_t port = lbpkit::Lbp16Transport::kPort;
    if (const auto colon = host.find(':'); colon != std::string::npos) {
      const auto text = host.substr(colon + 1);
      if (text.empty() || text.size() > 5 || text.find_first_not_of("0123456789") != std::string::npos ||
          std::stoul(text) > 65535)
        throw lbpkit::Error(fmt::format("--addr: \"{}\" is not a port number (0..65535)", text));
      port = static_cast<std::uint16_t>(std::stoul(text));
      host = host.substr(0, colon);
    }
    auto t = std::make_unique<lbpkit::Lbp16Transport>(host, port);
    const auto name = t->boardName();
    if (name.empty()) throw lbpkit::Error(fmt::format("{} answers but gives no board name", t->describe()));
    c.transport = std::move(t);
    c.info = lbpkit::readCardInfo(*c.transport);
    return c;
  }
  hm2::HostMot2Card::Options card;
  if (!o.state.empty()) card.first.fieldIo.nvFile = o.state;
  if (o.sinking) card.first.fieldIo.outputs = remote::OutputType::Sinking;
  auto sim = std::make_unique<lbpkit::SimTransport>(std::move(card));
  c.sim = sim.get();
  c.transport = std::move(sim);
  c.info = lbpkit::readCardInfo(*c.transport);
  return c;
}

ApiAddress parseApiAddress(const std::string& text, const std::string& host) {
  ApiAddress a{host, 27182};
  if (text.empty()) return a;
  const auto colon = text.rfind(':');
  const auto portText = colon == std::string::npos ? text : text.substr(colon + 1);
  if (colon != std::string::npos) a.host = text.substr(0, colon);
  if (a.host.empty()) a.host = "127.0.0.1";
  if (portText.empty() || portText.size() > 5 || portText.find_first_not_of("0123456789") != std::string::npos ||
      std::stoul(portText) < 1 || std::stoul(portText) > 65535)
    throw lbpkit::Error(fmt::format("--api: \"{}\" is not [ADDR:]PORT (a port is 1..65535)", text));
  a.port = static_cast<int>(std::stoul(portText));
  return a;
}

}  // namespace lbpkit::app

namespace lbpkit::app {

std::optional<unsigned> cpuOption(const std::string& text, std::string_view option) {
  try {
    return lbpkit::process::parseCpu(text, option);
  } catch (const std::invalid_argument& e) {
    throw lbpkit::Error(e.what());
  }
}

}  // namespace lbpkit::app
