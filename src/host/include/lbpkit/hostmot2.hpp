// SPDX-License-Identifier: MIT
// What a HostMot2 card says about itself: its IDROM, modules and pins,
// read and checked the way LinuxCNC's hostmot2 driver does.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "lbpkit/transport.hpp"
#include "lbpkit/wire/hostmot2.hpp"

namespace lbpkit {

struct ModuleInfo {
  std::uint8_t tag = 0;
  std::string name;  // "SSerial", "MuxedQCount", ... or "unknown-0xNN"
  std::uint8_t version = 0;
  std::uint8_t clockTag = 0;
  std::uint32_t clockHz = 0;
  std::uint8_t instances = 0;
  std::uint16_t baseAddress = 0;
  std::uint8_t registers = 0;
  std::uint32_t registerStride = 0;
  std::uint32_t instanceStride = 0;
  std::uint32_t multipleRegisters = 0;
};

struct PinInfo {
  unsigned io = 0;         // IO number
  unsigned connector = 0;  // 0-based port
  unsigned bit = 0;        // bit within the port
  std::uint8_t secondaryTag = 0;
  std::uint8_t secondaryUnit = 0;
  std::uint8_t secondaryPin = 0;
  [[nodiscard]] bool output() const { return (secondaryPin & wire::hm2::pin::kOutput) != 0; }
  // "SSerial 0 TX1 (out)", "MuxedQCount 1 IDX (in)", "GPIO".
  [[nodiscard]] std::string function() const;
};

struct CardInfo {
  std::string configName;  // "HOSTMOT2"
  std::string boardName;   // "MESA7I92"
  std::uint32_t idromType = 0;
  std::uint32_t fpgaSize = 0;
  std::uint32_t fpgaPins = 0;
  std::uint32_t ioPorts = 0;
  std::uint32_t ioWidth = 0;
  std::uint32_t portWidth = 0;
  std::uint32_t clockLow = 0;
  std::uint32_t clockHigh = 0;
  std::vector<ModuleInfo> modules;
  std::vector<PinInfo> pins;

  [[nodiscard]] const ModuleInfo* module(std::uint8_t tag) const;
  // Smart-serial channels wired to pins (from the pin descriptors).
  [[nodiscard]] unsigned sserialChannels() const;
};

// Reads and checks the identification area and IDROM. Throws lbpkit::Error
// naming the field that is wrong (bad cookie, IDROM type, port widths...).
CardInfo readCardInfo(Transport& t);

std::string moduleName(std::uint8_t tag);

}  // namespace lbpkit
