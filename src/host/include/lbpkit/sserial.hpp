// SPDX-License-Identifier: MIT
// The smart-serial (SSLBP) driver: start channels, discover their remotes,
// and run the real-time cycle (manual: SSLBP, NORMAL MODE OPERATION, SETUP
// MODE OPERATION, DISCOVERY SEQUENCE).
//
// Set-up (may allocate): SmartSerial(...), discover(), start(), find().
// The cycle (no allocation, no name lookups): set()/setBit(), cycle(),
// value()/bit(), status().
//
// Errors on the RS-422 link (a noisy cable, a remote that stops answering)
// are counted per channel, as LinuxCNC's hostmot2 driver counts them per
// port (its fault-count pin and fault-inc, fault-dec, fault-lim parameters,
// defaults 10, 1, 200): a cycle whose DOIT failed for the channel adds the
// increment, every cycle then takes off the decrement (not below 0), and a
// count above the limit is reported in CycleStatus::overLimitMask. With the
// defaults the count grows while more than one DOIT in ten fails, and 23
// failures in a row take it over the limit. SSLBP counts too: the 21st error of
// one kind since START sets TooManyErrors in CS (CycleStatus::
// tooManyErrorsMask), after which its error counts say nothing more until
// the channel is stopped and started again. Either way recover(slot) is the
// remedy: STOP of that channel and a normal START, which clears SSLBP's
// counts and the remote's faults, and sets the fault count to 0.
//
// Recovery is the caller's by default (Options::autoRecover false): a normal
// START blocks until the channel has started or given up, and COMMAND is
// busy meanwhile, so no channel gets a DOIT: on the in-process 7I77 about
// 0.9 ms when the remote answers (the quiet start timeout, the start
// sequence, the first chatter reply) and about 17 ms when it does not (the
// sequence retried until 20 timeouts are too many). That is one to 17
// periods of a 1 kHz servo thread, and the outputs of the restarted channel
// are off until its next DOIT (the START clears them, manual: NORMAL
// START). So a real-time caller chooses when (e.g. with the machine at
// rest, or from a slower thread), as LinuxCNC stops the port and waits for
// the user to toggle its run pin. With autoRecover, collectInputs() restarts
// the channels that need it at once, in one START (at most once per
// recoveryInterval per channel; CycleStatus::recoveredMask says which), and
// that cycle overruns by the START's time. Neither path allocates unless the
// card stops answering (the set-up commands then throw; collectInputs()
// catches that and sets CycleStatus::recoveryFailed).
#pragma once

#include <array>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "lbpkit/discovery.hpp"
#include "lbpkit/hostmot2.hpp"
#include "lbpkit/transport.hpp"
#include "lbpkit/wire/sslbp.hpp"

namespace lbpkit {

// The SSerial module's registers (HostMot2 regmap).
class SmartSerialRegisters {
 public:
  SmartSerialRegisters(const ModuleInfo& md, unsigned instance);
  [[nodiscard]] std::uint16_t command() const { return command_; }
  [[nodiscard]] std::uint16_t data() const { return data_; }
  [[nodiscard]] std::uint16_t cs(unsigned ch) const {
    return static_cast<std::uint16_t>(cs_ + wire::sslbp::reg::kChannelStride * ch);
  }
  [[nodiscard]] std::uint16_t interface(unsigned n, unsigned ch) const {
    return static_cast<std::uint16_t>(cs_ + (n + 1) * stride_ + wire::sslbp::reg::kChannelStride * ch);
  }

 private:
  std::uint16_t command_, data_, cs_;
  std::uint32_t stride_;
};

struct ChannelIdentity {
  unsigned channel = 0;
  bool present = false;
  std::uint32_t unitNumber = 0;
  std::string name;  // "7I77"
  std::uint16_t ptoc = 0;
  std::uint16_t gtoc = 0;
  std::uint32_t cs = 0;  // CS after START
  // 7I77 (unit number's top byte, as mesaflash does): "field I/O", "analog".
  [[nodiscard]] std::string function() const;
};

// A handle to one process data element, found at set-up time.
struct ElementRef {
  std::uint8_t slot = 0xFF;   // index into the driver's channels
  std::uint8_t element = 0xFF;
  [[nodiscard]] bool valid() const { return slot != 0xFF; }
};

// What one cycle saw. Inputs are unpacked only from a reply that came, and
// only for channels that answered; the others keep their last good values.
struct CycleStatus {
  bool ok = true;              // every exchange got its reply and every channel answered
  std::uint8_t failedMask = 0;  // DATA after DOIT
  bool commandBusy = false;     // COMMAND not clear at the start of the cycle (cycle too short)
  // An exchange of this cycle (from queueOutputs() on) got no reply in time
  // or could not be sent (Transport::linkCounters() says which). When the
  // outputs' exchange was the one lost, inputs that were read afterwards are
  // still unpacked: they are the card's registers as they are.
  bool replyLost = false;
  Nanoseconds doitTime{};       // from DOIT to COMMAND clear, as far as polling tells
  // Channels whose inputs this cycle brought: the DOIT succeeded (DATA) and
  // CS says the channel is running (a channel whose START failed is not
  // asked by DOIT, so DATA alone would not flag it). The other channels'
  // inputs are their last good values.
  std::uint8_t freshMask = 0;
  // Channels whose fault count is above Options::faultLimit.
  std::uint8_t overLimitMask = 0;
  // Channels whose CS shows TooManyErrors (sticky until STOP).
  std::uint8_t tooManyErrorsMask = 0;
  // Channels Options::autoRecover stopped and started again in this cycle
  // (their START failed if they are still in failedMask next cycle).
  std::uint8_t recoveredMask = 0;
  // autoRecover's STOP or START got no answer from the card (Error caught).
  bool recoveryFailed = false;
  // Channels that need recover(): over the fault limit or TooManyErrors.
  [[nodiscard]] std::uint8_t needsRecovery() const {
    return static_cast<std::uint8_t>(overLimitMask | tooManyErrorsMask);
  }
};

class SmartSerial {
 public:
  struct Options {
    unsigned instance = 0;
    std::uint8_t channelMask = 0xFF;          // channels to use
    std::array<std::uint8_t, 8> modes{};      // software mode per channel (CS top byte)
    Nanoseconds commandTimeout = std::chrono::seconds(2);
    Nanoseconds pollInterval = std::chrono::microseconds(10);
    Nanoseconds recoveryInterval = std::chrono::seconds(1);
    // The fault count (see the top of this file): LinuxCNC's defaults.
    std::uint32_t faultIncrement = 10;
    std::uint32_t faultDecrement = 1;
    std::uint32_t faultLimit = 200;
    // Restart channels that need it from collectInputs() (see the top of
    // this file for what that costs a cycle).
    bool autoRecover = false;
  };

  SmartSerial(Transport& t, const CardInfo& card, Options options);
  SmartSerial(Transport& t, const CardInfo& card) : SmartSerial(t, card, Options{}) {}
  ~SmartSerial();

  [[nodiscard]] unsigned channels() const { return channels_; }
  [[nodiscard]] const SmartSerialRegisters& registers() const { return regs_; }

  // --- Commands (each waits for COMMAND to clear; returns DATA) -------------
  std::uint8_t command(std::uint16_t cmd);
  std::uint8_t localRead(std::uint16_t address);
  void localWrite(std::uint16_t address, std::uint8_t value);
  std::uint8_t stopAll();
  // A channel's baud rate (SSLBP's local parameter, as hostmot2's
  // sserial_baudrate sets it): 115200 reaches a 7I77 in setup mode
  // (W4/W12). SSLBP takes it at the next STOP ALL (its global init).
  void setBaudRate(unsigned channel, std::uint32_t baud);
  [[nodiscard]] std::uint32_t baudRate(unsigned channel);
  // START (setup or normal) of the channels in `mask` with their modes.
  // Returns the mask of channels that failed.
  std::uint8_t start(std::uint8_t mask, bool setup);
  [[nodiscard]] ChannelIdentity identity(unsigned channel);

  // --- Setup mode ---------------------------------------------------------------
  // LBP access to a remote on a channel started in setup mode.
  std::unique_ptr<RemoteAccess> remote(unsigned channel);
  // STOP ALL, setup START, and discovery of every present remote in `mask`.
  // The remotes found are kept for start().
  std::vector<ChannelIdentity> discover(std::uint8_t mask = 0xFF);
  [[nodiscard]] const RemoteDescription& description(unsigned slot) const { return slots_.at(slot).description; }
  [[nodiscard]] const ChannelIdentity& slotIdentity(unsigned slot) const { return slots_.at(slot).identity; }
  [[nodiscard]] unsigned slots() const { return static_cast<unsigned>(slots_.size()); }
  struct DiscoveryStats {
    std::uint64_t doits = 0;
    Nanoseconds time{};
  };
  [[nodiscard]] const DiscoveryStats& discoveryStats() const { return discoveryStats_; }

  // --- Normal mode -------------------------------------------------------------------
  // STOP ALL and normal START of the discovered remotes. Throws if one fails.
  void startNormal();
  [[nodiscard]] ElementRef find(unsigned channel, const std::string& name) const;
  void set(ElementRef e, double value);
  void setRaw(ElementRef e, std::uint64_t raw);
  void setBit(ElementRef e, unsigned bit, bool on);
  [[nodiscard]] double value(ElementRef e) const;
  [[nodiscard]] std::uint64_t raw(ElementRef e) const;
  [[nodiscard]] bool bit(ElementRef e, unsigned n) const { return (raw(e) >> n) & 1U; }
  [[nodiscard]] std::uint32_t cs(unsigned slot) const { return slots_.at(slot).cs; }
  [[nodiscard]] std::uint8_t remoteFaults(unsigned slot) const {
    return static_cast<std::uint8_t>(slots_.at(slot).cs >> wire::sslbp::cs::kRemoteByteShift);
  }

  // Queue this cycle's output writes and the DOIT (the caller flushes, with
  // Transport::tryFlush(), so other modules' accesses share the exchange).
  void queueOutputs();
  // Wait for the DOIT, read CS and inputs, unpack. Needs the outputs flushed.
  // Never throws: a lost reply is reported in the status (the cycle path
  // uses tryFlush(), waiting at most the transport's cycle timeout).
  CycleStatus collectInputs();
  // Both, for a caller with nothing else to do (servoCycle() in
  // servo_cycle.hpp also reads the encoders in the same flush).
  CycleStatus cycle();
  // A channel that keeps failing is stopped and started again, at most once
  // per recoveryInterval; its fault count goes back to 0. Returns true when
  // it tried; running() then says whether the START brought it back.
  bool recover(unsigned slot);
  // The channel's fault count (LinuxCNC: fault-count).
  [[nodiscard]] std::uint32_t faultCount(unsigned slot) const { return slots_.at(slot).faultCount; }
  // Its last START (startNormal() or recover()) succeeded.
  [[nodiscard]] bool running(unsigned slot) const { return slots_.at(slot).running; }
  // Restarts recover() (or autoRecover) did on this channel.
  [[nodiscard]] std::uint64_t recoveries(unsigned slot) const { return slots_.at(slot).recoveries; }
  // Cycles whose inputs were read; cycles that lost a reply.
  [[nodiscard]] std::uint64_t cycles() const { return cycles_; }
  [[nodiscard]] std::uint64_t lostCycles() const { return lostCycles_; }

 private:
  struct Slot {
    ChannelIdentity identity;
    RemoteDescription description;
    // Packing plan, PTOC order: bit offsets in the interface registers.
    std::vector<unsigned> inOffset, outOffset;
    std::vector<std::uint64_t> raw;  // per element
    std::array<std::uint32_t, 3> ifOut{};
    std::array<std::uint32_t, 3> ifIn{};
    unsigned inRegs = 0, outRegs = 0;
    std::uint32_t cs = 0;
    Nanoseconds lastRecovery{-1};
    std::uint32_t faultCount = 0;
    std::uint64_t recoveries = 0;
    bool running = false;
  };
  // The fault count and the masks of one cycle whose DATA and CS were read.
  void countFaults(CycleStatus& st);
  // STOP of each channel of `slots` (a mask of slot indexes), one normal
  // START of them all; returns the channel mask that failed to start.
  std::uint8_t restart(std::uint8_t slotMask);
  std::uint8_t waitCommand();
  std::uint8_t runningMask() const;

  Transport& t_;
  Options options_;
  SmartSerialRegisters regs_;
  unsigned channels_;
  std::vector<Slot> slots_;
  DiscoveryStats discoveryStats_;
  std::uint64_t doits_ = 0;
  std::uint64_t cycles_ = 0;
  std::uint64_t lostCycles_ = 0;
  std::uint64_t failuresAtQueue_ = 0;  // the transport's failed exchanges when the outputs were queued
  std::uint32_t pollCommand_ = 0, pollData_ = 0;
  std::uint32_t doitWord_ = 0;
  Nanoseconds busyEstimate_{0};
  static constexpr Nanoseconds kMaxBusyEstimate = std::chrono::microseconds(500);
};

}  // namespace lbpkit
