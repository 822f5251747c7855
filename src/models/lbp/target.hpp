// SPDX-License-Identifier: MIT
// What an LBP parser talks to: the remote device behind the protocol.
#pragma once

#include <cstdint>
#include <optional>
#include <span>

#include "lbp/sim_time.hpp"

namespace lbpkit::model::lbp {

class Target {
 public:
  virtual ~Target() = default;

  // The byte-addressed data space reached by data read/write commands.
  virtual std::uint8_t readMemory(std::uint16_t address) = 0;
  // False when the byte cannot be written (read-only, unmapped, NV access
  // off): the parser then raises the Invalid write status bit.
  virtual bool writeMemory(std::uint16_t address, std::uint8_t value) = 0;

  // Whether the RPC table's addresses are something else right now (a
  // program flash's page buffer while NV access is flash): then writes
  // there need no RPCMEM flag.
  [[nodiscard]] virtual bool rpcTableOverlaid() const { return false; }

  // Device-specific local registers (card name, modes, faults, NV access...).
  // The parser itself keeps the protocol's own ones (status, CRC, RPCMEM,
  // timeout, address pointer, version, unit ID, RPC pitch/size, cookie).
  virtual std::optional<std::uint8_t> readLocal(std::uint8_t command) = 0;
  // False when the device has no such writable register (Invalid write).
  virtual bool writeLocal(std::uint8_t command, std::uint8_t value) = 0;

  // Hard-wired RPCs (0xBB..0xBD). Sizes are those of the current mode.
  struct RpcSizes {
    std::uint8_t fromHost = 0;  // data bytes that follow the RPC byte
    std::uint8_t toHost = 0;    // data bytes answered before the CRC
  };
  virtual std::optional<RpcSizes> specialRpc(std::uint8_t command) = 0;
  virtual void runSpecialRpc(std::uint8_t command, std::span<const std::uint8_t> fromHost,
                             std::span<std::uint8_t> toHost) = 0;

  // Bracket every command that arrived intact (CRC good). `begin` is host
  // communication (it feeds the watchdog) and lets the device bring inputs
  // up to date; `end` lets it act on what was written.
  virtual void beginCommand(SimTime now) = 0;
  virtual void endCommand(SimTime now) = 0;

  // 0xFE 0x5A: reset the LBP processor.
  virtual void resetProcessor() = 0;
};

}  // namespace lbpkit::model::lbp
