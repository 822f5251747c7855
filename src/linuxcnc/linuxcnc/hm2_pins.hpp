// SPDX-License-Identifier: MIT
// The HAL pins and parameters LinuxCNC's hostmot2 driver creates for a card
// (its IDROM: modules and pin descriptors) and the smart-serial remotes found
// on it (their PTOC and GTOC), given the driver's config= string. Naming and
// allocation follow what Debian's LinuxCNC 2.9 does (tests/interop/pins_test.cpp
// checks pin for pin against it); no network, no LinuxCNC needed.
#pragma once

#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "lbpkit/discovery.hpp"
#include "lbpkit/hostmot2.hpp"

namespace lbpkit::linuxcnc {

enum class Kind : std::uint8_t { Pin, Param };
enum class Type : std::uint8_t { Bit, Float, S32, U32 };
// Pins: In (HAL reads it from a signal: the driver's input), Out, IO.
// Parameters: RO or RW.
enum class Dir : std::uint8_t { In, Out, IO, RO, RW };

std::string kindName(Kind k);
std::string typeName(Type t);
std::string dirName(Dir d);  // as halcmd shows it: IN OUT I/O RO RW

// What an item belongs to: a message for people ("7I77 on smart-serial port
// 0 channel 0 (mode 0)", "encoder 3", "IO pin 17 (connector 0 pin 17):
// GPIO"), and the same as data for the checks that ask.
struct Origin {
  enum class Kind : std::uint8_t { Module, Function, Remote, IoPin };
  Kind kind = Kind::Module;
  std::string text;
  // Function: the function's name; Remote: the remote's ("7I77"); IoPin:
  // what the pin does ("GPIO", or its module function).
  std::string name;
  unsigned port = 0, channel = 0;  // Remote: where it answers
  Origin() = default;
  // A module's items: the message is all there is to it.
  Origin(std::string message) : text(std::move(message)) {}  // NOLINT(google-explicit-constructor)
  Origin(const char* message) : text(message) {}             // NOLINT(google-explicit-constructor)
  static Origin function(std::string name);
  static Origin remote(std::string text, std::string name, unsigned port, unsigned channel);
  static Origin ioPin(std::string text, std::string function);
};

struct Item {
  std::string name;
  Kind kind = Kind::Pin;
  Type type = Type::Bit;
  Dir dir = Dir::Out;
  // A parameter LinuxCNC names twice (hal_param_alias): halcmd shows `name`,
  // setp also takes this one (the gpio.NNN name of a module's output pin).
  std::string alsoNamed;
  Origin origin;
};

// The hostmot2 driver's config= modparam (hostmot2(9)): the module counts
// (-1: all the firmware has) and the smart-serial modes per port.
struct Hm2Config {
  std::map<std::string, int> counts;                 // "num_encoders" -> 6
  std::map<unsigned, std::string> sserialPorts;      // 0 -> "00xxxx"
  bool sserialPortGiven = false;
  [[nodiscard]] int count(const std::string& key) const;  // -1 when not given
  // The mode character of a channel: '0'..'9' or 'x' (LinuxCNC: channels past
  // the string are mode 0).
  [[nodiscard]] char mode(unsigned port, unsigned channel) const;
  [[nodiscard]] std::uint8_t channelMask(unsigned port) const;
};

// Parses "num_encoders=6 sserial_port_0=00xxxx". Unknown tokens and bad
// values are listed in `problems` (LinuxCNC refuses to load on them).
Hm2Config parseHm2Config(const std::string& text, std::vector<std::string>* problems = nullptr);
std::string hm2ConfigKeys();  // the accepted keys, for messages

struct Remote {
  unsigned port = 0;      // SSerial instance
  unsigned channel = 0;
  std::string name;       // "7I77" (unit's name)
  unsigned mode = 0;      // software mode it was started in
  RemoteDescription description;
};

enum class Driver : std::uint8_t { Eth, Pci };

// "hm2_7i92.0": LinuxCNC's name for the first board of that kind, from
// the IDROM's board name (what hm2_pci goes by).
std::string boardPrefix(const CardInfo& card, unsigned index = 0);
// "hm2_7i96s.0" from hm2_eth's board name ("7i96s").
std::string boardPrefix(const std::string& halName, unsigned index);

// hm2_eth's name for a board from its LBP16 board name (hm2_eth.c's table):
// "7I92T" -> "7i92" (four characters), "7I96S" -> "7i96s", "7I80HD-25" ->
// "7i80", "7I76E-16" -> "7i76e".
std::string hm2EthBoardName(const std::string& lbp16Name);

// Every pin and parameter, sorted by name. `remotes`: one per channel that
// answered and that the configuration enables. `halName`: hm2_eth's name of
// the board ("7i96s"; empty: from the IDROM's board name, as hm2_pci does).
std::vector<Item> hostmot2Items(const CardInfo& card, const Hm2Config& config, const std::vector<Remote>& remotes,
                                Driver driver, unsigned boardIndex = 0, const std::string& halName = {});

// The LEDs LinuxCNC gives a board (its low-level driver's table).
unsigned ledCount(const std::string& boardName);

// The instances of each module hostmot2 makes HAL names for, as the
// firmware has them, by the HAL name: "encoder", "stepgen", "pwmgen",
// "dpll", "inm", "ssr", "outm" -> count (absent: no such module).
std::map<std::string, unsigned> moduleInstances(const CardInfo& card);

// The module counts the configuration asks for beyond what the firmware has
// ("num_stepgens=6, but the firmware has 5 StepGens"): hostmot2 refuses to
// load then ("config.num_stepgens=6, but only 5 are available, not loading
// driver").
std::vector<std::string> hm2CountProblems(const CardInfo& card, const Hm2Config& config);

}  // namespace lbpkit::linuxcnc
