// SPDX-License-Identifier: MIT
// The SSerial module running SSLBP, HostMot2's smart-serial firmware for
// LBP remotes (manual: REFERENCE INFORMATION, SSLBP; firmware behaviour from
// Mesa's SSLBP source; docs/protocol-facts.md#sslbp).
//
// Registers (lbpkit/wire/hostmot2_modules.hpp; per instance, base + i*0x40;
// channel c at +4c):
//   COMMAND  W M R D S T T T | N..N (16 bits; writes with bit 31 set are ignored)
//   DATA     8 bits; what the host writes is not what it reads back.
//            While M is set: the 16-bit program ROM word COMMAND bits 10..0 address
//   CS       per channel control (host writes: mode / setup LBP command)
//            and status (reads: local faults, status, COM_STATE, remote faults)
//   interface 0..2, per channel, independent in and out data
//
// The firmware is modelled as SSLBP's per-channel state machine: every LBP
// transaction takes the characters it takes on the wire at the channel's baud
// rate plus the remote's turnaround, so command completion times (and the
// COMMAND register reading non-zero until then) come out of the model.
#pragma once

#include <array>
#include <cstdint>

#include "hostmot2/module.hpp"
#include "hostmot2/serial_link.hpp"
#include "lbpkit/wire/sslbp.hpp"

namespace lbpkit::model::hm2 {

// CS bits and COMMAND values are wire facts the driver shares.
namespace cs = lbpkit::wire::sslbp::cs;
namespace command = lbpkit::wire::sslbp::command;

// Local parameters: the map is a wire fact; where the channel blocks sit and
// how big the RAM is are this firmware's (SSLBP 1.43) values.
namespace local {
// The map's parameters (wire::sslbp::local), by name.
using wire::sslbp::local::kBaudOffset;
using wire::sslbp::local::kChannels;
using wire::sslbp::local::kChannelStart;
using wire::sslbp::local::kChannelStride;
using wire::sslbp::local::kInterfaceType;
using wire::sslbp::local::kInterfaceWidth;
using wire::sslbp::local::kMajorRev;
using wire::sslbp::local::kMinorRev;
using wire::sslbp::local::kProcessorType;
using wire::sslbp::local::kRxSizeOffset;
using wire::sslbp::local::kTxSizeOffset;
inline constexpr std::uint16_t kChannelBlock = 0x70;
inline constexpr std::uint16_t kChannelBlockStride = 0x32;
inline constexpr std::uint16_t kRamSize = 0x200;
// Above the RAM, read-only I/O (firmware: SSLBP.EQU clock, hardnchannel): the
// interface clock in Hz (32 bits, little-endian) and the hardware channel count,
// which is also what local 7 (kChannels) is set from.
inline constexpr std::uint16_t kInterfaceClock = 0x230;
inline constexpr std::uint16_t kHardwareChannels = 0x234;
}  // namespace local

class Sslbp final : public Module {
 public:
  static constexpr unsigned kMaxChannels = 8;
  static constexpr const ModuleKind& kKind = map::kSSerial;
  static constexpr std::uint16_t kCommand = kKind.address(map::sserial::kCommand);
  static constexpr std::uint16_t kData = kKind.address(map::sserial::kData);
  static constexpr std::uint16_t kCs = kKind.address(map::sserial::kCs);
  static constexpr std::uint16_t kInterface0 = kKind.address(map::sserial::kInterface0);
  static constexpr std::uint8_t kMajorRevision = 0x01;
  static constexpr std::uint8_t kMinorRevision = 0x2B;  // 43, the ROM Mesa ships
  static constexpr std::uint32_t kDefaultBaud = 2500000;
  static constexpr std::uint32_t kInterfaceClockHz = 100000000;  // the 7I92's SSerial clock
  // The processor's program ROM (sserialwa.vhd: 2k x 16, host access with M set).
  // lbpkit does not contain Mesa's SSLBP program: the ROM is a placeholder, all
  // zero but for the ROM cookie SSLBP.ASM puts in its last word, and what the
  // host downloads is kept but not executed (the model is the firmware).
  static constexpr unsigned kRomWords = 2048;
  static constexpr std::uint16_t kRomCookieAddress = 0x7FF;
  static constexpr std::uint16_t kRomCookie = 0xABCD;

  explicit Sslbp(unsigned channels, unsigned instance = 0);

  [[nodiscard]] bool decodes(std::uint16_t address) const override;
  std::uint32_t readRegister(std::uint16_t address, SimTime now) override;
  WriteResult writeRegister(std::uint16_t address, std::uint32_t value, SimTime now) override;
  // Inline and one comparison until something is due (wake_): the card
  // advances every module at every host access.
  void advance(SimTime now) override {
    if (now >= wake_) runEvents(now);
  }
  // Power-up: the FPGA's configuration (the ROM holds the bitfile's program,
  // here the placeholder), then the firmware's initmem and init (local RAM,
  // baud rates, every channel stopped, DATA 0xAA). The cables (links) stay
  // attached.
  void reset() override;

  [[nodiscard]] unsigned channels() const { return channelCount_; }
  SerialLink& link(unsigned channel) { return channels_.at(channel).link; }

  // --- External remotes (lbpkit sim --remote CH=pty) -------------------------
  // A channel whose link is external (SerialLink::setExternal) sends its
  // frames to the link's outbox and waits for another process to answer.
  // That process answers through a pseudo-terminal, scheduled by the
  // operating system: milliseconds, where a remote on the cable answers in
  // microseconds. So every reply timeout of an external channel (the START
  // steps' 400 us / 1.2 ms, chatter's 400 us, the DOIT timeout of measured
  // round trip + 40 us, setup mode's 50 ms) is kExternalTimeoutFactor times
  // the firmware's: 40 ms for a START step, enough for a process woken by
  // the kernel on a loaded machine, or behind a USB-RS422 adapter with a
  // 1..16 ms latency timer. The quiet periods (not reply timeouts) stay.
  static constexpr std::int64_t kExternalTimeoutFactor = 100;
  // Reply bytes from the external remote on `channel`, arrived at `now`:
  // judged as a model's reply once the expected count is in (CRC, late);
  // bytes nobody waits for land in the receive FIFO as leftovers.
  void remoteBytes(unsigned channel, std::span<const std::uint8_t> bytes, SimTime now);

  // Observation (what the registers would read, without side effects).
  [[nodiscard]] std::uint16_t commandRegister() const { return command_; }
  [[nodiscard]] std::uint8_t dataRegister() const { return dataOut_; }
  [[nodiscard]] std::uint32_t csRegister(unsigned channel) const;
  [[nodiscard]] std::uint32_t interfaceRegister(unsigned channel, unsigned n) const {
    return channels_.at(channel).ifIn[n];
  }
  [[nodiscard]] bool channelRunning(unsigned channel) const { return channels_.at(channel).ready; }
  [[nodiscard]] std::uint32_t channelBaud(unsigned channel) const { return channels_.at(channel).baud; }
  // M set: the processor is held in reset.
  [[nodiscard]] bool processorInReset() const { return inReset_; }
  // A program ROM word as written so far (a host write lands 50 ns after
  // its DATA write).
  [[nodiscard]] std::uint16_t romWord(unsigned address) const { return rom_.at(address); }
  struct Counters {
    std::uint64_t commands = 0;
    std::uint64_t doits = 0;
    std::uint64_t lostCommands = 0;  // written while busy
    std::uint64_t transactions = 0;
  };
  [[nodiscard]] const Counters& counters() const { return counters_; }

  // What an observer sees: the registers as they would read, each channel's
  // state and its link to the remote.
  struct ErrorTotals {
    std::uint64_t crc = 0;
    std::uint64_t invalidCookie = 0;
    std::uint64_t overrun = 0;
    std::uint64_t timeout = 0;
    std::uint64_t extraCharacter = 0;
    std::uint64_t serialBreak = 0;
    std::uint64_t remoteFault = 0;
  };
  struct State {
    struct Channel {
      bool running = false;  // started: blathering, or serving setup requests
      std::uint32_t cs = 0;
      std::uint8_t remoteFaults = 0;  // the remote's fault byte, CS bits 31..24
      std::uint32_t baud = kDefaultBaud;
      bool cableConnected = true;
      SerialLink::Counters link;
      // Every error the channel has judged since power-up, by kind (the CS
      // bits are sticky until STOP, and the firmware's own counts, which
      // raise TooManyErrors, start again at each START).
      ErrorTotals errors;
    };
    std::uint16_t command = 0;
    std::uint8_t data = 0;
    Counters counters;
    unsigned channels = 0;  // the first `channels` entries are valid
    std::array<Channel, kMaxChannels> channel{};
  };
  [[nodiscard]] State state() const;

 private:
  enum class Mode : std::uint8_t { Stopped, Normal, Setup };
  enum class Outcome : std::uint8_t { Ok, Timeout, CrcError, Break };

  struct Channel {
    SerialLink link;
    std::uint32_t baud = kDefaultBaud;
    Mode mode = Mode::Stopped;
    std::uint8_t state = 0;  // COM_STATE: the firmware's chanstate
    std::uint8_t status = 0xC1;
    std::uint8_t errorLog = 0;
    std::uint8_t remoteFault = 0;
    std::array<std::uint8_t, 7> errorCounts{};
    ErrorTotals errorTotals;
    bool ready = false;       // started: blathering, or serving setup requests
    bool startPending = false;  // in the current START
    bool requested = false;   // DOIT request
    bool invalid = false;     // no good reply to the current DOIT
    bool doitSeen = false;    // first DOIT done: no more chatter
    bool leftover = false;    // characters left in the receive FIFO
    std::uint8_t rxSize = 0;
    std::uint8_t txSize = 0;
    std::uint8_t nameIndex = 0;
    std::uint8_t setupExpect = 0;  // reply bytes of the setup-mode command in flight
    SimTime measuredRpc{};
    SimTime due{};  // its next event, while its bit in scheduled_ is set
    // Host-written and firmware-written halves of the per-channel registers.
    std::uint32_t csOut = 0;
    std::array<std::uint32_t, 3> ifOut{};
    std::array<std::uint32_t, 3> ifIn{};
    // The transaction in flight.
    Outcome outcome = Outcome::Ok;
    std::array<std::uint8_t, 16> reply{};
    SimTime sentAt{};
    // External link: the reply collected so far, until judged or timed out.
    bool awaiting = false;
    std::uint8_t expect = 0;
    std::uint8_t externalSize = 0;
    std::array<std::uint8_t, 24> external{};
    SimTime deadline{};
  };

  void runEvents(SimTime now);
  WriteResult store(std::uint16_t address, std::uint32_t value, SimTime now);  // writeRegister's work
  // The earliest time anything is due: the running immediate command's end,
  // or a channel's next step (SimTime::max() if nothing is).
  [[nodiscard]] SimTime nextEvent() const;
  void execute(std::uint16_t cmd, SimTime now);
  void complete(std::uint8_t data, SimTime now);
  void globalInit();
  // SSLBP.MAC initmem: RAM 0x000..0x0FF cleared, identity and default baud
  // rates written (at power-up and when M is released).
  void initMem();
  void finishBoot();
  void initChannel(Channel& c);
  void startChannels(std::uint8_t mask, Mode mode, SimTime now);
  void doit(std::uint8_t mask, SimTime now);
  void checkCommandDone(SimTime now);
  // The per-channel state machine, by phase (sslbp.cpp says which manual
  // section each follows).
  void step(unsigned index, SimTime now);
  void startSequence(unsigned index, SimTime now);
  void sendStartRow(Channel& c, unsigned row, SimTime now);
  void chatter(Channel& c, SimTime now);
  void runNormal(Channel& c, SimTime now);
  void runSetup(Channel& c, SimTime now);
  void sendProcessData(Channel& c, bool zeros, std::uint8_t waitState, SimTime timeout, SimTime now);
  bool timedOut(Channel& c);
  void transact(Channel& c, std::span<const std::uint8_t> frame, unsigned expect, SimTime timeout,
                std::uint8_t waitState, SimTime now);
  // What the channel makes of a reply whose `expect` data bytes and CRC were
  // complete at `arrival` (any bytes past them are extra), sent at c.sentAt
  // and due by `deadline`; schedules the channel's next step. Both the
  // cable's synchronous replies and an external remote's come through here.
  void judge(Channel& c, std::span<const std::uint8_t> reply, bool breakSeen, SimTime arrival, unsigned expect,
             SimTime deadline);
  void setError(Channel& c, std::uint8_t bit, unsigned counter);
  void restart(Channel& c, SimTime now);
  void schedule(Channel& c, SimTime at);
  void unschedule(Channel& c);
  // START step timeouts count the firmware's hardware timer ticks: the time
  // from `now` to the reply timeout, and to the end of the quiet period.
  [[nodiscard]] SimTime startTimeout(const Channel& c, SimTime now) const;
  [[nodiscard]] SimTime startQuiet(const Channel& c, SimTime now) const;
  // The time of the n-th tick strictly after t.
  [[nodiscard]] SimTime tickAfter(SimTime t, unsigned n) const;

  unsigned instance_;
  unsigned channelCount_;
  std::array<Channel, kMaxChannels> channels_{};
  std::uint8_t scheduled_ = 0;  // bit i: channel i has an event at channels_[i].due
  std::array<std::uint8_t, local::kRamSize> ram_{};

  std::uint16_t command_ = 0;
  std::uint8_t dataIn_ = 0;   // host-written
  std::uint8_t dataOut_ = 0;  // firmware-written
  bool inReset_ = false;  // M set: the processor held in reset
  // Boot: M released, the processor's initmem runs (immediateDone_ is its end).
  enum class Busy : std::uint8_t { Idle, Start, Doit, Immediate, Boot } busy_ = Busy::Idle;
  std::array<std::uint16_t, kRomWords> rom_{};
  // A host ROM write in flight (sserialwa.vhd synchronises it to the processor clock).
  struct RomWrite {
    bool pending = false;
    std::uint16_t address = 0;
    std::uint16_t value = 0;
    SimTime at{};
  } romWrite_;
  std::uint8_t commandMask_ = 0;
  std::uint8_t immediateData_ = 0;
  SimTime immediateDone_{};
  bool lost_ = false;
  // nextEvent() as of the last change (advance, write, reset): advance() has
  // nothing to do before then, and the card advances every module at every
  // host access.
  SimTime wake_{};
  // The hardware timer: the tick period the last START set (0: none since
  // power-up) and the time of one of its ticks.
  SimTime tickPeriod_{};
  SimTime tickOrigin_{};
  Counters counters_;
};

}  // namespace lbpkit::model::hm2
