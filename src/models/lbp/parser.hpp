// SPDX-License-Identifier: MIT
// The LBP command parser of a remote device (manual: LBP, FRAMING).
//
// Framing is by pre-parsing: the header says how many bytes the command has
// (address, stream data, CRC), RPC headers by walking the stored RPC list.
// A gap between characters longer than the command timeout resets the parser,
// so it is ready for the next command even after noise. Every complete
// command with a good CRC is answered with its read data plus a CRC byte; a
// command without read data gets the lone CRC byte 0x00, except 0xFE 0x5A,
// which restarts the processor and answers nothing. A bad CRC is counted
// and flagged in the status, and nothing is executed or answered (the host
// sees a timeout, which is how SSLBP notices it).
#pragma once

#include <algorithm>
#include <array>
#include <cstdint>
#include <optional>
#include <span>

#include "lbp/protocol.hpp"
#include "lbp/sim_time.hpp"
#include "lbp/target.hpp"

namespace lbpkit::model::lbp {

struct ParserConfig {
  std::uint16_t rpcSize = 0x200;        // RPC table at 0..rpcSize-1 (64 RPCs of pitch 8)
  std::uint8_t version = 0x01;          // 0xDA
  bool crcAlwaysEnabled = true;         // manual: "CRCs are always enabled on the 7I77"
  std::uint8_t commandTimeout = 255;    // tenths of a character time (255 = 25.5, setup mode)
  std::uint32_t baud = 115200;          // character time for framing gaps
};

class Parser {
 public:
  // Largest command the buffer holds: header, 2 address bytes, and up to 255
  // stream bytes of an RPC, plus the CRC.
  static constexpr std::size_t kMaxCommand = 260;
  // Largest answer: an RPC list filling the whole table with 8-byte reads.
  static constexpr std::size_t kMaxResponse = 4096;

  Parser(Target& target, ParserConfig config);

  // One character arrived (its stop bit ended at `now`). Returns the bytes to
  // send back, completed by this character (empty for most characters).
  // The returned span stays valid until the next call.
  // Inline: it runs for every character of every SSLBP transaction.
  std::span<const std::uint8_t> receive(std::uint8_t byte, SimTime now) {
    responseLength_ = 0;
    advance(now);
    haveLast_ = true;
    last_ = now;
    if (skipping_) return {};
    if (length_ == 0) {
      startCommand(byte);
      if (length_ == 0) return {};
    }
    const std::size_t received = received_ + 1;
    command_[received_] = byte;
    received_ = received;
    if (received == length_) complete(now);
    return {response_.data(), responseLength_};
  }

  // A whole special RPC (manual: SPECIAL RPCS) whose characters arrived
  // `ch` apart, the first ending at `first`, between commands: what
  // receive() of each character would do, at once. Characters `ch` apart
  // never let a gap pass, so only the last one matters. Anything else (a
  // half-received command, skipping, another command, a frame that is not
  // exactly one command) returns nullopt with nothing changed: the caller
  // hands the characters over one by one.
  std::optional<std::span<const std::uint8_t>> receiveSpecialRpc(std::span<const std::uint8_t> frame, SimTime first,
                                                                 SimTime ch) {
    if (length_ != 0 || skipping_ || frame.size() < 2 || commandType(frame[0]) != CommandType::Rpc) return std::nullopt;
    const auto sizes = target_.specialRpc(frame[0]);
    if (!sizes || frame.size() != std::size_t{2} + sizes->fromHost) return std::nullopt;
    responseLength_ = 0;
    haveLast_ = true;
    last_ = first + ch * static_cast<SimTime::rep>(frame.size() - 1);
    std::copy(frame.begin(), frame.end(), command_.begin());
    length_ = frame.size();
    complete(last_);
    return std::span<const std::uint8_t>{response_.data(), responseLength_};
  }

  // Let time pass without characters: a half-received command times out.
  // Between commands (the usual case, checked at every host access) a gap
  // changes nothing: only a half-received command or skipping is ended by one.
  void advance(SimTime now) {
    if ((length_ != 0 || skipping_) && haveLast_ && gapExpired(now)) endGap();
  }
  // The earliest time advance() can change anything: when the gap after the
  // last character expires with a command half received or characters being
  // skipped; SimTime::max() between commands. Valid until the next receive(),
  // reset() or configuration change.
  [[nodiscard]] SimTime gapDeadline() const {
    return (length_ == 0 && !skipping_) || !haveLast_ ? SimTime::max() : last_ + gap_;
  }

  // Power-up / processor reset: every parser variable to its initial value.
  void reset();

  // Power-up values (applied by the next reset()) and the line rate.
  void setConfig(const ParserConfig& config) {
    config_ = config;
    updateGap();
  }
  void setBaud(std::uint32_t baud) {
    config_.baud = baud;
    updateGap();
  }
  [[nodiscard]] std::uint32_t baud() const { return config_.baud; }

  // Protocol state, readable by the device and by tests.
  [[nodiscard]] std::uint8_t status() const { return status_; }
  void raiseStatus(std::uint8_t bits) { status_ = static_cast<std::uint8_t>(status_ | bits); }
  void clearStatus(std::uint8_t bits) { status_ = static_cast<std::uint8_t>(status_ & ~bits); }
  [[nodiscard]] std::uint8_t crcErrorCount() const { return crcErrors_; }
  [[nodiscard]] bool rpcMemEnabled() const { return rpcMem_; }
  [[nodiscard]] std::uint16_t addressPointer() const { return address_; }
  [[nodiscard]] std::uint8_t commandTimeout() const { return timeout_; }
  [[nodiscard]] bool midCommand() const { return length_ > 0; }
  // Commands thrown away whole: unknown headers and bytes skipped until a gap.
  [[nodiscard]] std::uint32_t discardedCommands() const { return discarded_; }

 // One stored command of an RPC list (manual: RPC COMMANDS): a data header,
  // its address when AS is set, and its data when RID is set.
  struct StoredCommand {
    DataCommand cmd;
    std::uint16_t address = 0;
    std::array<std::uint8_t, 8> inlineData{};
  };
  // Stored commands of one RPC list the parser keeps (a 512-byte table of
  // one-byte commands).
  static constexpr std::size_t kMaxRpcList = 512;

 private:
  void startCommand(std::uint8_t header);
  void execute(SimTime now);
  void executeData(DataCommand cmd, const std::uint8_t*& stream, std::uint16_t address, bool addressGiven,
                   const std::uint8_t* inlineData);
  void executeLocal(std::uint8_t header, std::uint8_t value);
  void executeRpc(std::uint8_t header, const std::uint8_t* stream);
  void emit(std::uint8_t byte);
  void abandon(std::uint8_t statusBits);
  void endGap();
  void complete(SimTime now);  // the last character of a command came: execute it
  bool gapExpired(SimTime now) const { return now - last_ >= gap_; }
  void updateGap();

  Target& target_;
  ParserConfig config_;

  // Local LBP variables.
  std::uint8_t status_ = 0;
  bool crcEnabled_ = true;
  std::uint8_t crcErrors_ = 0;
  bool rpcMem_ = false;
  std::uint8_t timeout_ = 255;
  std::uint16_t address_ = 0;
  std::uint8_t unitId_ = 0;

  // Framing.
  std::array<std::uint8_t, kMaxCommand> command_{};
  std::size_t received_ = 0;
  std::size_t length_ = 0;  // expected length including CRC; 0 = idle
  bool skipping_ = false;   // discarding characters until the next gap
  bool haveLast_ = false;
  SimTime last_{};
  // From the end of a character, the time after which the gap has expired
  // (updateGap(): from the baud rate and the timeout register).
  SimTime gap_{};
  std::uint32_t discarded_ = 0;

  std::array<std::uint8_t, kMaxResponse + 1> response_{};  // data, then the CRC
  std::array<StoredCommand, kMaxRpcList> rpcList_{};  // the RPC being received, taken at its header
  std::size_t rpcLength_ = 0;
  std::size_t responseLength_ = 0;
};

}  // namespace lbpkit::model::lbp
