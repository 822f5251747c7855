// SPDX-License-Identifier: MIT
// What every lbpkit tool shares: how to reach a card, and output helpers.
#pragma once

#include <CLI/CLI.hpp>

#include <array>
#include <atomic>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "lbpkit/hostmot2.hpp"
#include "linuxcnc/config_check.hpp"
#include "sim_card/sim_transport.hpp"
#include "lbpkit/sserial.hpp"
#include "lbpkit/transport.hpp"

namespace lbpkit::app {

extern std::atomic<bool> gStop;
void installSignalHandlers();
// Readable once SIGINT or SIGTERM came (an eventfd; -1 before
// installSignalHandlers()): a thread asleep in poll() wakes on it.
int stopFd();

// --sim (the in-process virtual card, the default) or --addr IP.
struct CardOptions {
  bool sim = false;
  std::string addr;
  std::string state;   // EEPROM file of the virtual 7I77's field I/O processor
  // Per channel from 0: a mode digit, or x to leave the channel alone; channels
  // past the string run in mode 0 (LinuxCNC's sserial_port_0 semantics).
  std::string modes;
  bool sinking = false;

  void add(CLI::App& cmd);
  [[nodiscard]] lbpkit::SmartSerial::Options serialOptions() const;
};

struct Card {
  std::unique_ptr<lbpkit::Transport> transport;
  lbpkit::SimTransport* sim = nullptr;  // the virtual card's world, with --sim
  lbpkit::CardInfo info;
};
Card openCard(const CardOptions& o);

std::filesystem::path defaultStateDir();

// A sim's control API: --api [ADDR:]PORT (ADDR defaults to `host`).
struct ApiAddress {
  std::string host;
  int port = 27182;  // `lbpkit sim --api`'s default
};
// Throws lbpkit::Error naming what is wrong with `text`.
ApiAddress parseApiAddress(const std::string& text, const std::string& host);

// What a board a configuration loads may be, from the card catalogue (as
// lbpkit check-config models it; cmd_check_config.cpp): `card` and
// `pinout` narrow it down when not empty.
lbpkit::linuxcnc::BoardModel catalogueBoardModel(std::string card, std::string pinout);

// The machine `ini` expects, written to `out` (over an existing file only
// with `force`) once it loads as lbpkit sim loads it; what the derivation
// found goes to stderr. Returns the file's text; throws lbpkit::Error when
// there is no machine (cmd_machine.cpp).
std::string deriveMachineFile(const std::filesystem::path& ini, const std::filesystem::path& out, bool force);

// A --cpu option: N|last|any (lbpkit::process::parseCpu), an error naming
// the CPUs this process may use as lbpkit::Error.
std::optional<unsigned> cpuOption(const std::string& text, std::string_view option = "--cpu");

}  // namespace lbpkit::app

void addRemoteCommand(CLI::App& app);
void addInfoCommand(CLI::App& app);
void addDiscoverCommand(CLI::App& app);
void addParameterCommands(CLI::App& app);
void addMonitorCommand(CLI::App& app);
void addSimCommand(CLI::App& app);
void addFaultCommand(CLI::App& app);
void addPinsCommand(CLI::App& app);
void addCheckConfigCommand(CLI::App& app);
void addBenchCommand(CLI::App& app);
void addLinuxCncCommand(CLI::App& app);  // cmd_linuxcnc.cpp
void addMachineCommand(CLI::App& app);   // cmd_machine.cpp
void addRehearseCommand(CLI::App& app);  // cmd_rehearse.cpp
