// SPDX-License-Identifier: MIT
#include "hostmot2/sslbp.hpp"

#include <algorithm>
#include <bit>

#include "lbp/protocol.hpp"

namespace lbpkit::model::hm2 {

namespace {

// One pass of the firmware's main loop between steps of a channel.
constexpr SimTime kPass = SimTime{2000};  // 2 us
// START timeouts (firmware: 200 ticks of 2 us normal, 6 ticks of 200 us setup).
constexpr SimTime kNormalStartTimeout = SimTime{400'000};
// START step timeouts count ticks of the firmware's hardware timer, which each
// START sets to 2 us (normal) or 200 us (setup): a reply is late at the 200th
// (6th) tick after its request, the quiet period ends at the 201st (7th) tick.
// The new rate starts when the tick running at the START ends, so a normal
// START after setup mode waits up to 200 us longer (docs/sslbp-vs-firmware.md).
constexpr SimTime kNormalTick = SimTime{2'000};
constexpr SimTime kSetupTick = SimTime{200'000};
constexpr unsigned kNormalStartTicks = 200;
constexpr unsigned kSetupStartTicks = 6;
// From a START command to its first channel step: the firmware computes the
// timer divisor first (measured on SSLBP 43: first request 1.42 ms after a
// SETUP START).
constexpr SimTime kStartLatency = SimTime{18'000};
// A START that starts no channel (e.g. channels 3..7 on a 3-channel SSLBP, as
// mesaflash's loop to local 1 asks for) still runs that divisor computation
// before the firmware's channel check: SSLBP 43 completes it 18.3-18.5 us after
// the command (18.29 us as the comparison's host polls).
constexpr SimTime kNoChannelStart = SimTime{18'400};
// M released: the processor boots and its initmem clears the RAM before the
// command register is cleared (SSLBP.ASM; SSLBP 43: COMMAND clears 21.5-21.6 us
// after the write that releases M, for LinuxCNC's 0x4000, 0x0001 and
// mesaflash's 0x4800, 0x0800 alike).
constexpr SimTime kBoot = SimTime{21'500};
// A host write of a ROM word (M set) reaches the ROM a few processor clocks
// after the DATA write (sserialwa.vhd: on the trailing edge of the
// synchronised write request). SSLBP 43: a DATA read 20 ns after the write
// still returns the old word, 100 ns after it the new one.
constexpr SimTime kRomWriteDelay = SimTime{50};
constexpr std::uint16_t kRomAddressMask = Sslbp::kRomWords - 1;  // COMMAND bits 10..0
// initmem clears the RAM up to here only (SSLBP.MAC: until X's high byte is 1).
constexpr std::uint16_t kInitMemEnd = 0x100;
// STOP ALL: the global init's time, per channel and fixed (measured on SSLBP 43).
constexpr SimTime kUartInit = SimTime{15'180};
constexpr SimTime kStopAllBase = SimTime{1'350};
// Run timeouts: the measured chatter round trip plus 40 us in normal mode;
// 50 ms in setup mode (room for flash writes).
constexpr SimTime kTimeoutFudge = SimTime{40'000};
constexpr SimTime kSetupRunTimeout = SimTime{50'000'000};
// 20 errors of one kind since START are tolerated; the 21st sets TooManyErrors.
constexpr std::uint8_t kMaxErrors = 20;
constexpr std::uint8_t kLbpCharTimeout = 40;  // bit times: "4 character times"

// Per-kind error counters (firmware order).
enum Counter : unsigned { kCrc, kCookie, kOverrun, kTimeoutCount, kExtra, kBreak, kRemFault };

// The firmware's chanstate values: each transaction has a send state and the
// wait state shown while the reply is outstanding (COM_STATE, CS byte 2).
enum State : std::uint8_t {
  kStartTimer = 0x01,
  kWaitTimeout = 0x02,
  kCookieWait = 0x04,
  kCharTimeoutWait = 0x06,
  kClearStatusWait = 0x08,
  kReadStatusWait = 0x0A,
  kUnitWait = 0x0D,
  kNameWait = 0x0F,  // 0x0F, 0x11, 0x13, 0x15
  kSetModeWait = 0x1B,
  kDiscoveryWait = 0x1D,
  kClearOutputsWait = 0x1F,
  kSetClearFaultWait = 0x21,
  kPollClearFaultWait = 0x23,
  kReadFaultWait = 0x25,
  kBlather = 0x3A,
  kBlatherWait = 0x3B,
  kSetupRun = 0x40,
  kSetupRunWait = 0x41,
  kRun = 0x42,
  kRunWait = 0x43,
};

}  // namespace

Sslbp::Sslbp(unsigned channels, unsigned instance)
    : Module(kKind, kKind.base, 1, kKind.version), instance_(instance), channelCount_(std::min<unsigned>(channels, kMaxChannels)) {
  Sslbp::reset();
}

void Sslbp::reset() {
  // A freshly configured FPGA: every channel variable (the host-written
  // halves of CS and the interface registers too, and the remote fault byte
  // that STOP and, for channels 3.., the boot leave alone), the command state
  // and the local RAM start from zero. The cable to each remote is not the card's and stays; the
  // counters are the simulator's and keep counting.
  for (auto& c : channels_) {
    const SerialLink link = c.link;
    c = Channel{};
    c.link = link;
  }
  scheduled_ = 0;
  command_ = 0;
  dataIn_ = 0;
  dataOut_ = 0;
  tickPeriod_ = SimTime{};
  tickOrigin_ = SimTime{};
  inReset_ = false;
  busy_ = Busy::Idle;
  commandMask_ = 0;
  immediateData_ = 0;
  immediateDone_ = SimTime{};
  lost_ = false;
  // The configured FPGA: the ROM holds the bitfile's program (the placeholder,
  // see kRomWords), the RAM its initial values (0 here: the firmware's
  // pre-initialised strings are not modelled).
  rom_.fill(0);
  rom_[kRomCookieAddress] = kRomCookie;
  romWrite_ = RomWrite{};
  ram_.fill(0);
  initMem();
  globalInit();
  wake_ = nextEvent();
}

void Sslbp::initMem() {
  std::fill(ram_.begin(), ram_.begin() + kInitMemEnd, std::uint8_t{0});
  // The channels' remote fault bytes live in that RAM (chanremfault, block
  // offset 0x25): cleared for the channels whose block starts below 0x100
  // (0..2 with SSLBP's 0x70 + 0x32 per channel), kept for the others.
  for (unsigned i = 0; i < channelCount_; ++i)
    if (local::kChannelBlock + i * local::kChannelBlockStride + 0x25 < kInitMemEnd) channels_[i].remoteFault = 0;
  ram_[local::kInterfaceType] = 0x12;
  ram_[local::kInterfaceWidth] = 8;
  ram_[local::kMajorRev] = kMajorRevision;
  ram_[local::kMinorRev] = kMinorRevision;
  ram_[local::kChannelStart] = local::kChannelBlock;
  ram_[local::kChannelStride] = local::kChannelBlockStride;
  ram_[local::kProcessorType] = 0xD8;
  ram_[local::kChannels] = static_cast<std::uint8_t>(channelCount_);
  // "whatisupport": the remotes with built-in knowledge (8I20, 7I64).
  const char supported[] = "8I207I64";
  std::copy_n(supported, 8, ram_.begin() + 8);
  for (unsigned c = 0; c < kMaxChannels; ++c) {
    const auto at = local::kChannelBlock + c * local::kChannelBlockStride + local::kBaudOffset;
    for (unsigned i = 0; i < 4; ++i) ram_[at + i] = static_cast<std::uint8_t>(kDefaultBaud >> (8 * i));
  }
}

// The map's descriptor (version 0, 6 registers, instance stride select 1:
// 0x40, registers 2..5 per channel) is what LinuxCNC's driver checks for
// Sslbp. Each instance answers in its 0x40 window: COMMAND and DATA
// at every word of it, CS and the interfaces for its channels.
bool Sslbp::decodes(std::uint16_t address) const {
  if (address < kCommand || address >= kInterface0 + 3 * kRegisterStride) return false;
  if (((address & 0xFFU) / kInstanceStride1) != instance_) return false;
  // CS and interface registers exist only for the channels the instance has
  // (COMMAND and DATA are one per instance, whatever the low bits).
  return (address & 0xFF00U) < kCs || (address & 0x3FU) / 4 < channelCount_;
}

// --- Registers -------------------------------------------------------------------

std::uint32_t Sslbp::csRegister(unsigned channel) const {
  const auto& c = channels_.at(channel);
  return static_cast<std::uint32_t>(c.errorLog) | (static_cast<std::uint32_t>(c.status) << 8) |
         (static_cast<std::uint32_t>(c.state) << 16) | (static_cast<std::uint32_t>(c.remoteFault) << 24);
}

Sslbp::State Sslbp::state() const {
  State s;
  s.command = command_;
  s.data = dataOut_;
  s.counters = counters_;
  s.channels = channelCount_;
  for (unsigned ch = 0; ch < channelCount_; ++ch) {
    const auto& c = channels_[ch];
    const auto csValue = csRegister(ch);
    s.channel[ch] = {c.ready, csValue, static_cast<std::uint8_t>(csValue >> cs::kRemoteByteShift), c.baud,
                     c.link.connected(), c.link.counters(), c.errorTotals};
  }
  return s;
}

std::uint32_t Sslbp::readRegister(std::uint16_t address, SimTime now) {
  advance(now);
  const std::uint16_t block = address & 0xFF00U;
  const unsigned ch = (address & 0x3FU) / 4;
  if (block == kCommand) return command_;
  // M set: DATA reads the ROM word COMMAND bits 10..0 address, 16 bits
  // (sserialwa.vhd: romwrena selects romdata for host DATA reads).
  if (block == kData) return inReset_ ? rom_[command_ & kRomAddressMask] : dataOut_;
  if (ch >= channelCount_) return 0;
  if (block == kCs) return csRegister(ch);
  return channels_[ch].ifIn[static_cast<unsigned>(block - kInterface0) / kRegisterStride];
}

WriteResult Sslbp::writeRegister(std::uint16_t address, std::uint32_t value, SimTime now) {
  const WriteResult r = store(address, value, now);
  wake_ = nextEvent();  // a command may have started something
  return r;
}

WriteResult Sslbp::store(std::uint16_t address, std::uint32_t value, SimTime now) {
  advance(now);
  const std::uint16_t block = address & 0xFF00U;
  const unsigned ch = (address & 0x3FU) / 4;
  if (block == kCommand) {
    // COMMAND REGISTER WRITE IGNORE: bit 31 set means "no command" (DMA/TRAM).
    if (value & command::kIgnore) return WriteResult::IgnoredCommand;
    const auto cmd = static_cast<std::uint16_t>(value & 0xFFFFU);
    ++counters_.commands;
    if (cmd & command::kReset) {
      // M (manual: COMMAND REGISTER, "ROM enable/reset bit"; sserialwa.vhd
      // romwrena): the processor is held in reset while it is set, stopped
      // where it stands: the command running is abandoned, no channel steps,
      // and CS and the interface registers keep what they read (SSLBP 43: CS
      // 0x0400C100, the remote's fault byte too, while M is held). COMMAND
      // bits 10..0 address the ROM for DATA accesses.
      inReset_ = true;
      command_ = cmd;
      busy_ = Busy::Idle;
      lost_ = false;
      scheduled_ = 0;
      return WriteResult::Accepted;
    }
    if (inReset_) {
      // Released: the processor boots (SSLBP.ASM: initmem, then
      // commandcomplete, then the global init). The command written with M
      // clear is never run: the boot clears it (SSLBP 43: 0x2003 written to
      // release M reads back until COMMAND clears 21.6 us later; DATA is then
      // 0xAA, not the version).
      inReset_ = false;
      command_ = cmd;
      busy_ = Busy::Boot;
      immediateDone_ = now + kBoot;
      return WriteResult::Accepted;
    }
    if (busy_ == Busy::Boot) {
      // Written while the processor boots: the boot's command clear (or its
      // global init, which clears the doorbell) drops it.
      command_ = cmd;
      ++counters_.lostCommands;
      return WriteResult::LostCommand;
    }
    if (busy_ != Busy::Idle) {
      // "The command register should not be written when non-zero": the
      // firmware takes only a STOP while busy (the manual promises STOP ALL
      // always works); anything else is lost and the running command then
      // completes with DATA = 0xFF.
      if ((cmd >> 8) != (command::kStop >> 8)) {
        command_ = cmd;
        lost_ = true;
        ++counters_.lostCommands;
        return WriteResult::LostCommand;
      }
      busy_ = Busy::Idle;
      lost_ = false;
    }
    command_ = cmd;
    execute(cmd, now);
    return WriteResult::Accepted;
  }
  if (block == kData) {
    dataIn_ = static_cast<std::uint8_t>(value & 0xFFU);
    // M set: the write also goes to the ROM word COMMAND bits 10..0 address
    // (16 bits; sserialwa.vhd hloadrom/loadrom), a few clocks later.
    if (inReset_)
      romWrite_ = RomWrite{true, static_cast<std::uint16_t>(command_ & kRomAddressMask),
                           static_cast<std::uint16_t>(value & 0xFFFFU), now + kRomWriteDelay};
    return WriteResult::Accepted;
  }
  if (ch >= channelCount_) return WriteResult::Unmapped;
  if (block == kCs)
    channels_[ch].csOut = value;
  else
    channels_[ch].ifOut[static_cast<unsigned>(block - kInterface0) / kRegisterStride] = value;
  return WriteResult::Accepted;
}

// --- Commands ----------------------------------------------------------------------

void Sslbp::execute(std::uint16_t cmd, SimTime now) {
  const auto high = static_cast<std::uint8_t>(cmd >> 8);
  const auto existing = static_cast<std::uint8_t>((1U << channelCount_) - 1);
  const auto mask = static_cast<std::uint8_t>(cmd & 0xFFU);
  busy_ = Busy::Immediate;
  immediateDone_ = now + kPass;
  if (high & 0x10) {  // DOIT is tested first: any command with D set
    ++counters_.doits;
    doit(static_cast<std::uint8_t>(mask & existing), now);
  } else if (high == (command::kStart >> 8)) {
    startChannels(mask, Mode::Normal, now);  // channels that do not exist fail
  } else if (high == (command::kSetupStart >> 8)) {
    startChannels(mask, Mode::Setup, now);
  } else if (high == (command::kStop >> 8)) {
    if (mask == 0) {
      globalInit();  // STOP ALL: every channel variable reset, DATA = 0xAA
      immediateData_ = 0xAA;
      // The firmware's global init sets up each channel's UART (a 32-bit
      // division): SSLBP 43 takes 46.9 us with 3 channels, 92.4 us with 6.
      immediateDone_ = now + kStopAllBase + kUartInit * channelCount_;
    } else {
      for (unsigned i = 0; i < channelCount_; ++i)
        if (mask & (1U << i)) initChannel(channels_[i]);
      immediateData_ = static_cast<std::uint8_t>(mask & ~existing);
    }
  } else if (high & (command::kRequest >> 8)) {
    // Local parameter access: R (and W) with the address in the low bits.
    const std::uint16_t addr = cmd & 0x0FFFU;
    if (high & (command::kWrite >> 8)) {
      if (addr < ram_.size()) ram_[addr] = dataIn_;
      immediateData_ = dataOut_;
    } else {
      immediateData_ = addr < ram_.size() ? ram_[addr] : 0;  // 0x200.. is I/O space
      if (addr >= local::kInterfaceClock && addr < local::kInterfaceClock + 4)
        immediateData_ = static_cast<std::uint8_t>(kInterfaceClockHz >> (8 * (addr - local::kInterfaceClock)));
      if (addr == local::kHardwareChannels) immediateData_ = static_cast<std::uint8_t>(channelCount_);
    }
  } else {
    immediateData_ = 0xFF;  // unknown command
  }
}

void Sslbp::complete(std::uint8_t data, SimTime) {
  command_ = 0;
  dataOut_ = lost_ ? 0xFF : data;
  lost_ = false;
  busy_ = Busy::Idle;
}

void Sslbp::finishBoot() {
  // initmem (the RAM, the remote fault bytes, the default baud rates), the
  // command cleared, then the global init (every channel stopped, DATA 0xAA).
  // lbpkit runs the global init at once: a command written right after
  // COMMAND clears is run, where the firmware, still in its global init
  // (about 47 us with 3 channels), would lose it (docs/sslbp-vs-firmware.md).
  initMem();
  command_ = 0;
  lost_ = false;
  busy_ = Busy::Idle;
  globalInit();
}

void Sslbp::globalInit() {
  for (unsigned i = 0; i < channelCount_; ++i) {
    auto& c = channels_[i];
    initChannel(c);
    const auto at = local::kChannelBlock + i * local::kChannelBlockStride + local::kBaudOffset;
    std::uint32_t baud = 0;
    for (unsigned k = 0; k < 4; ++k) baud |= static_cast<std::uint32_t>(ram_[at + k]) << (8 * k);
    c.baud = baud ? baud : kDefaultBaud;
  }
  dataOut_ = 0xAA;
}

void Sslbp::initChannel(Channel& c) {
  c.mode = Mode::Stopped;
  c.status = 0xC1;
  c.errorLog = 0;
  c.state = 0;
  // CS byte 3, the remote's fault byte, is left alone: the firmware's stop and
  // channel init rewrite CS bytes 2..0 only (SSLBP 43 after a LowVoltageFault:
  // CS 0x2000C100 after STOP 0x0803 and after STOP ALL, 0x20400000 after the
  // next SETUP START). Only the boot after the M bit clears it (initMem).
  c.errorCounts.fill(0);
  c.ready = c.startPending = c.requested = c.invalid = c.doitSeen = c.leftover = false;
  unschedule(c);
  c.awaiting = false;
  c.externalSize = 0;
  c.rxSize = c.txSize = 0;
  // The host-read interface registers are cleared, all of them: initchannel
  // (SSLBP.MAC) skips byte 2 of interface 0, but sserialwa.vhd's 8-to-32-bit
  // shim writes a register only with its byte 3, taking bytes 0..2 from a
  // latch that each register write clears, so byte 2 is written 0 too (SSLBP
  // 43: interface 0 0x00FF0000, inputs 16..23 on, reads 0 after STOP 0x0801
  // and 100 us after STOP ALL).
  c.ifIn[0] = 0;
  c.ifIn[1] = 0;
  c.ifIn[2] = 0;
}

void Sslbp::startChannels(std::uint8_t mask, Mode mode, SimTime now) {
  busy_ = Busy::Start;
  commandMask_ = mask;
  // The timer divisor is loaded; the tick running then still ends at its old rate.
  const SimTime loaded = now + kStartLatency;
  if (tickPeriod_ > SimTime{} && loaded > tickOrigin_)
    tickOrigin_ += ((loaded - tickOrigin_ + tickPeriod_ - SimTime{1}) / tickPeriod_) * tickPeriod_;
  else
    tickOrigin_ = loaded;
  tickPeriod_ = mode == Mode::Setup ? kSetupTick : kNormalTick;
  for (unsigned i = 0; i < channelCount_; ++i) {
    auto& c = channels_[i];
    if (!(mask & (1U << i)) || c.ready || c.mode != Mode::Stopped) continue;  // START only starts new channels
    c.mode = mode;
    c.errorCounts.fill(0);
    c.startPending = true;
    c.state = kStartTimer;
    schedule(c, loaded + kPass);
  }
  checkCommandDone(now);
  // Nothing to start: the command still took the divisor computation.
  if (busy_ == Busy::Immediate) immediateDone_ = now + kNoChannelStart;
}

void Sslbp::doit(std::uint8_t mask, SimTime now) {
  busy_ = Busy::Doit;
  commandMask_ = 0;
  for (unsigned i = 0; i < channelCount_; ++i) {
    auto& c = channels_[i];
    if (!(mask & (1U << i)) || !c.ready) continue;  // channels not running are not requested
    commandMask_ = static_cast<std::uint8_t>(commandMask_ | (1U << i));
    c.requested = true;
    c.invalid = true;
    c.doitSeen = true;
    if (c.state == kRun || c.state == kSetupRun) schedule(c, now + kPass);
    // A chattering channel picks the request up at its next good reply.
  }
  checkCommandDone(now);
}

void Sslbp::checkCommandDone(SimTime now) {
  // Channels the instance does not have never start.
  auto bits = static_cast<std::uint8_t>(busy_ == Busy::Start ? ~((1U << channelCount_) - 1) : 0);
  for (unsigned i = 0; i < channelCount_; ++i) {
    const auto& c = channels_[i];
    if (busy_ == Busy::Start && c.startPending) return;
    if (busy_ == Busy::Doit && c.requested) return;
    if (busy_ == Busy::Start && !c.ready) bits = static_cast<std::uint8_t>(bits | (1U << i));
    if (busy_ == Busy::Doit && c.invalid) bits = static_cast<std::uint8_t>(bits | (1U << i));
  }
  if (busy_ == Busy::Start || busy_ == Busy::Doit) {
    // START: channels asked for that are not running; DOIT: channels without
    // a good reply (manual: NORMAL START, DOIT).
    busy_ = Busy::Immediate;
    immediateData_ = static_cast<std::uint8_t>(bits & commandMask_);
    immediateDone_ = now + kPass;
  }
}

// --- Time ---------------------------------------------------------------------------

void Sslbp::schedule(Channel& c, SimTime at) {
  scheduled_ = static_cast<std::uint8_t>(scheduled_ | (1U << (&c - channels_.data())));
  c.due = at;
}

void Sslbp::unschedule(Channel& c) {
  scheduled_ = static_cast<std::uint8_t>(scheduled_ & ~(1U << (&c - channels_.data())));
}

SimTime Sslbp::nextEvent() const {
  SimTime t = busy_ == Busy::Immediate || busy_ == Busy::Boot ? immediateDone_ : SimTime::max();
  if (romWrite_.pending && romWrite_.at < t) t = romWrite_.at;
  for (unsigned m = scheduled_; m != 0; m &= m - 1) {
    const SimTime due = channels_[static_cast<unsigned>(std::countr_zero(m))].due;
    if (due < t) t = due;
  }
  return t;
}

void Sslbp::runEvents(SimTime now) {
  // Events in time order; at equal times a finishing command goes first.
  for (;;) {
    SimTime at = now;
    int which = -2;  // -1: the running immediate command or boot; >= 0: a channel
    if (romWrite_.pending && romWrite_.at <= now) {
      rom_[romWrite_.address] = romWrite_.value;
      romWrite_.pending = false;
    }
    if ((busy_ == Busy::Immediate || busy_ == Busy::Boot) && immediateDone_ <= at) {
      at = immediateDone_;
      which = -1;
    }
    for (unsigned m = scheduled_; m != 0; m &= m - 1) {  // in channel order: the lowest first at equal times
      const auto i = static_cast<unsigned>(std::countr_zero(m));
      const auto& c = channels_[i];
      if (c.due <= now && (which == -2 || c.due < at)) {
        at = c.due;
        which = static_cast<int>(i);
      }
    }
    if (which == -2) break;
    if (which == -1) {
      if (busy_ == Busy::Boot)
        finishBoot();
      else
        complete(immediateData_, at);
    } else {
      auto& c = channels_[static_cast<unsigned>(which)];
      unschedule(c);
      if (c.awaiting) {  // an external reply's timeout: what came stays in the FIFO
        c.awaiting = false;
        if (c.externalSize > 0) c.leftover = true;
      }
      step(static_cast<unsigned>(which), at);
    }
  }
  wake_ = nextEvent();
}

SimTime Sslbp::tickAfter(SimTime t, unsigned n) const {
  if (tickPeriod_ <= SimTime{}) return t + kNormalTick * n;
  if (t < tickOrigin_) return tickOrigin_ + tickPeriod_ * (n - 1);
  return tickOrigin_ + tickPeriod_ * ((t - tickOrigin_) / tickPeriod_ + n);
}

SimTime Sslbp::startTimeout(const Channel& c, SimTime now) const {
  return tickAfter(now, c.mode == Mode::Setup ? kSetupStartTicks : kNormalStartTicks) - now;
}

SimTime Sslbp::startQuiet(const Channel& c, SimTime now) const {
  return tickAfter(now, (c.mode == Mode::Setup ? kSetupStartTicks : kNormalStartTicks) + 1) - now;
}

void Sslbp::setError(Channel& c, std::uint8_t bit, unsigned counter) {
  c.errorLog = static_cast<std::uint8_t>(c.errorLog | bit);
  c.status = static_cast<std::uint8_t>(c.status | cs::kStatusCommunicationError);
  auto& t = c.errorTotals;
  std::uint64_t* const total[] = {&t.crc, &t.invalidCookie, &t.overrun, &t.timeout,
                                  &t.extraCharacter, &t.serialBreak, &t.remoteFault};  // Counter's order
  ++*total[counter];
  if (c.errorCounts[counter] < kMaxErrors)
    ++c.errorCounts[counter];
  else
    c.errorLog = static_cast<std::uint8_t>(c.errorLog | cs::kTooManyErrors);
}

void Sslbp::restart(Channel& c, SimTime now) {
  c.state = kStartTimer;
  if (c.errorLog & cs::kTooManyErrors) {
    // The channel has failed: START completes without it (COM_STATE 1 then,
    // firmware: dogetcookie); while other channels still start, it goes on
    // trying.
    c.startPending = false;
    checkCommandDone(now);
    if (busy_ != Busy::Start) return;
  }
  schedule(c, now + kPass);
}

void Sslbp::transact(Channel& c, std::span<const std::uint8_t> body, unsigned expect, SimTime timeout,
                           std::uint8_t waitState, SimTime now) {
  if (c.leftover) {  // characters still in the receive FIFO before a transmit
    setError(c, cs::kExtraCharacter, kExtra);
    c.leftover = false;
  }
  std::array<std::uint8_t, 24> frame{};
  const std::size_t n = std::min(body.size(), frame.size() - 1);
  std::copy_n(body.begin(), n, frame.begin());
  frame[n] = lbp::crc8({frame.data(), n});
  const auto reply = c.link.exchange({frame.data(), n + 1}, now, c.baud);
  ++counters_.transactions;
  c.sentAt = now;
  c.state = waitState;
  if (c.link.external()) {
    // Another process answers, later (remoteBytes); until the relaxed
    // timeout the channel waits as it would for the cable.
    c.outcome = Outcome::Timeout;
    c.awaiting = true;
    c.expect = static_cast<std::uint8_t>(std::min<std::size_t>(expect, c.external.size() - 1));
    c.externalSize = 0;
    c.deadline = now + timeout * kExternalTimeoutFactor;
    schedule(c, c.deadline);
    return;
  }
  const std::size_t need = expect + 1;
  const SimTime ch = lbp::characterTime(c.baud);
  const SimTime arrival =
      reply.size >= need ? reply.lastByteAt - ch * static_cast<std::int64_t>(reply.size - need) : reply.lastByteAt;
  judge(c, {reply.bytes.data(), reply.size}, reply.breakSeen, arrival, expect, now + timeout);
}

void Sslbp::judge(Channel& c, std::span<const std::uint8_t> reply, bool breakSeen, SimTime arrival,
                        unsigned expect, SimTime deadline) {
  const std::size_t need = expect + 1;
  c.outcome = Outcome::Timeout;
  SimTime due = deadline;
  if (reply.size() >= need) {
    if (breakSeen) {
      setError(c, cs::kSerialBreak, kBreak);  // the reply is discarded
      c.outcome = Outcome::Break;
    } else if (arrival > deadline) {
      c.leftover = true;  // too late: it lands in the FIFO after the timeout
    } else if (lbp::crc8(reply.first(need)) != 0) {
      setError(c, cs::kCrcError, kCrc);  // discarded; the channel then times out
      c.outcome = Outcome::CrcError;
    } else {
      c.outcome = Outcome::Ok;
      std::copy_n(reply.begin(), std::min(expect, static_cast<unsigned>(c.reply.size())), c.reply.begin());
      c.leftover = reply.size() > need;
      due = std::max(arrival, c.sentAt) + kPass;
    }
  } else if (!reply.empty()) {
    c.leftover = true;  // a partial reply stays in the FIFO
  }
  schedule(c, due);
}

void Sslbp::remoteBytes(unsigned channel, std::span<const std::uint8_t> bytes, SimTime now) {
  // A timeout due by now happens first: bytes after it came too late.
  advance(now);
  Channel& c = channels_.at(channel);
  if (bytes.empty()) return;
  if (!c.awaiting) {
    c.leftover = true;  // nobody waits for them: they sit in the receive FIFO
    return;
  }
  for (std::uint8_t b : bytes) {
    if (c.externalSize < c.external.size()) c.external[c.externalSize++] = b;
  }
  if (c.externalSize < c.expect + 1U) return;
  c.awaiting = false;
  // Everything in this batch arrived together: any bytes past the reply are
  // extra characters, as on the cable.
  judge(c, {c.external.data(), c.externalSize}, false, now, c.expect, c.deadline);
  wake_ = nextEvent();
}

// --- The per-channel state machine (SSLBP.JMP's "dochannel") -----------------------
//
// A channel is in one of four phases, told apart by its COM_STATE (CS byte 2,
// docs/protocol-facts.md#sslbp-cs-register): the start sequence (START and
// SETUP START), chatter (normal START done, no DOIT yet), the normal run
// (DOIT) and the setup-mode run (DOIT after SETUP START).

namespace {

// The start sequence as a table (docs/protocol-facts.md#sslbp-start-and-timeouts;
// manual: NORMAL START, SETUP START). Each row is one LBP transaction: what
// is sent, how many reply bytes are expected, the wait state COM_STATE shows
// while the reply is outstanding, what a good reply must be, and the state
// the sequence goes on to. Every row waits a START step timeout.
enum class Payload : std::uint8_t {
  Fixed,            // the row's bytes
  SoftwareMode,     // the row's command byte, then the remote mode the host wrote to CS byte 3
                    // (manual: REMOTE MODE IS WRITTEN TO CSR MS BYTE BEFORE START)
  ZeroProcessData,  // the process data RPC with every output 0 ("outputs off")
};
// A missing or damaged reply is counted as a timeout, then:
enum class OnTimeout : std::uint8_t {
  Restart,  // the sequence starts over from its quiet period
  Retry,    // the row is sent again, until errors are too many
};
// What is done with a good reply.
enum class OnReply : std::uint8_t {
  Next,           // nothing to check
  Cookie,         // must be the LBP cookie, else InvalidCookie and restart
  StatusClear,    // the LBP status must be 0, else RemoteFault and restart
  UnitNumber,     // into interface 0
  NameByte,       // one card name character into interface 1
  Discovery,      // RX/TX sizes into RAM, PTOC/GTOC into interface 2; SETUP START ends here
  PollUntilZero,  // the fault clear is done when its flag reads 0: ask again until then
  FaultsClear,    // remote faults must read 0: report them and ask again until too many
};
struct StartRow {
  std::uint8_t wait;    // COM_STATE while the reply is outstanding
  Payload payload;
  std::array<std::uint8_t, 2> bytes;
  std::uint8_t length;  // of `bytes` sent (Fixed)
  std::uint8_t expect;  // reply data bytes (ZeroProcessData: the discovered RX size)
  OnTimeout onTimeout;
  bool setupGoesOn;     // SETUP START takes a missing reply here and goes on without it
  OnReply onReply;
  std::uint8_t next;    // the next row's wait state, or kBlather: the sequence is done
};
constexpr std::uint8_t kNameChars = 4;
constexpr StartRow kStartRows[] = {
    {kCookieWait, Payload::Fixed, {lbp::local_read::kCookie, 0}, 1, 1, OnTimeout::Restart, false, OnReply::Cookie,
     kCharTimeoutWait},
    {kCharTimeoutWait, Payload::Fixed, {lbp::local_write::kCommandTimeout, kLbpCharTimeout}, 2, 0,
     OnTimeout::Restart, false, OnReply::Next, kClearStatusWait},
    {kClearStatusWait, Payload::Fixed, {lbp::local_write::kStatus, 0x00}, 2, 0, OnTimeout::Restart, false,
     OnReply::Next, kReadStatusWait},
    {kReadStatusWait, Payload::Fixed, {lbp::local_read::kStatus, 0}, 1, 1, OnTimeout::Restart, false,
     OnReply::StatusClear, kUnitWait},
    // Normal START insists on a unit number: every miss counts and it asks again.
    {kUnitWait, Payload::Fixed, {lbp::special_rpc::kUnitNumber, 0}, 1, 4, OnTimeout::Retry, true,
     OnReply::UnitNumber, kNameWait},
    {kNameWait, Payload::Fixed, {lbp::local_read::kCardName0, 0}, 1, 1, OnTimeout::Restart, false,
     OnReply::NameByte, kNameWait + 2},
    {kNameWait + 2, Payload::Fixed, {lbp::local_read::kCardName0 + 1, 0}, 1, 1, OnTimeout::Restart, false,
     OnReply::NameByte, kNameWait + 4},
    {kNameWait + 4, Payload::Fixed, {lbp::local_read::kCardName0 + 2, 0}, 1, 1, OnTimeout::Restart, false,
     OnReply::NameByte, kNameWait + 6},
    {kNameWait + 6, Payload::Fixed, {lbp::local_read::kCardName0 + 3, 0}, 1, 1, OnTimeout::Restart, false,
     OnReply::NameByte, kSetModeWait},
    // Not an 8I20 or 7I64 (those have hard-wired paths): the generic path.
    {kSetModeWait, Payload::SoftwareMode, {lbp::local_write::kRemoteSwMode, 0}, 1, 0, OnTimeout::Restart, false,
     OnReply::Next, kDiscoveryWait},
    {kDiscoveryWait, Payload::Fixed, {lbp::special_rpc::kDiscovery, 0}, 1, 6, OnTimeout::Restart, true,
     OnReply::Discovery, kClearOutputsWait},
    // From here on normal START only (SETUP START does no device setup).
    {kClearOutputsWait, Payload::ZeroProcessData, {0, 0}, 0, 0, OnTimeout::Retry, false, OnReply::Next,
     kSetClearFaultWait},
    {kSetClearFaultWait, Payload::Fixed, {lbp::local_write::kClearFault, 0xFF}, 2, 0, OnTimeout::Restart, false,
     OnReply::Next, kPollClearFaultWait},
    {kPollClearFaultWait, Payload::Fixed, {lbp::local_read::kClearFault, 0}, 1, 1, OnTimeout::Restart, false,
     OnReply::PollUntilZero, kReadFaultWait},
    {kReadFaultWait, Payload::Fixed, {lbp::local_read::kFaultStatus, 0}, 1, 1, OnTimeout::Restart, false,
     OnReply::FaultsClear, kBlather},
};
constexpr unsigned kStartRowCount = sizeof kStartRows / sizeof kStartRows[0];

// The row whose reply a channel in wait state `state` is waiting for;
// kStartRowCount if none is.
constexpr unsigned startRowWaitingIn(std::uint8_t state) {
  for (unsigned r = 0; r < kStartRowCount; ++r)
    if (kStartRows[r].wait == state) return r;
  return kStartRowCount;
}

// The table is walked by its `next` column: each row must lead to one that
// exists (or to chatter), and the wait states must tell the rows apart.
constexpr bool startTableConsistent() {
  for (unsigned r = 0; r < kStartRowCount; ++r) {
    if (startRowWaitingIn(kStartRows[r].wait) != r) return false;
    if (kStartRows[r].next != kBlather && startRowWaitingIn(kStartRows[r].next) == kStartRowCount) return false;
  }
  return kStartRows[startRowWaitingIn(kNameWait + 2 * (kNameChars - 1))].next == kSetModeWait;
}
static_assert(startTableConsistent());

std::uint32_t littleEndian32(const std::array<std::uint8_t, 16>& b, unsigned at) {
  return static_cast<std::uint32_t>(b[at]) | (static_cast<std::uint32_t>(b[at + 1]) << 8) |
         (static_cast<std::uint32_t>(b[at + 2]) << 16) | (static_cast<std::uint32_t>(b[at + 3]) << 24);
}

}  // namespace

void Sslbp::step(unsigned index, SimTime now) {
  Channel& c = channels_[index];
  switch (c.state) {
    case kBlather:
    case kBlatherWait: return chatter(c, now);
    case kRun:
    case kRunWait: return runNormal(c, now);
    case kSetupRun:
    case kSetupRunWait: return runSetup(c, now);
    default: return startSequence(index, now);
  }
}

bool Sslbp::timedOut(Channel& c) {
  // A damaged reply (CRC, break) was discarded: the channel saw no reply.
  if (c.outcome == Outcome::Ok) return false;
  setError(c, cs::kTimeout, kTimeoutCount);
  return true;
}

void Sslbp::sendProcessData(Channel& c, bool zeros, std::uint8_t waitState, SimTime timeout, SimTime now) {
  std::array<std::uint8_t, 13> f{};
  f[0] = lbp::special_rpc::kProcessData;
  for (unsigned i = 0; i < c.txSize && i < 12; ++i)
    f[1 + i] = zeros ? std::uint8_t{0} : static_cast<std::uint8_t>(c.ifOut[i / 4] >> (8 * (i % 4)));
  transact(c, {f.data(), 1U + std::min<unsigned>(c.txSize, 12)}, c.rxSize, timeout, waitState, now);
}

void Sslbp::sendStartRow(Channel& c, unsigned row, SimTime now) {
  const StartRow& r = kStartRows[row];
  switch (r.payload) {
    case Payload::Fixed: transact(c, {r.bytes.data(), r.length}, r.expect, startTimeout(c, now), r.wait, now); return;
    case Payload::SoftwareMode: {
      const std::array<std::uint8_t, 2> f{r.bytes[0], static_cast<std::uint8_t>(c.csOut >> 24)};
      transact(c, f, r.expect, startTimeout(c, now), r.wait, now);
      return;
    }
    case Payload::ZeroProcessData: sendProcessData(c, true, r.wait, startTimeout(c, now), now); return;
  }
}

// START and SETUP START (manual: NORMAL START, SETUP START;
// docs/protocol-facts.md#sslbp-start-and-timeouts, #sslbp-setup-mode): a
// quiet start timeout so the remote's parser resets, then the rows of
// kStartRows in order. Normal START ends in chatter; SETUP START ends after
// discovery with the channel serving setup requests.
void Sslbp::startSequence(unsigned index, SimTime now) {
  Channel& c = channels_[index];
  // A channel that failed its START stops trying once the command is over.
  if (!c.startPending && busy_ != Busy::Start) return;
  if (c.state == kStartTimer) {
    // Stay silent for a start timeout so the remote's parser resets.
    c.state = kWaitTimeout;
    schedule(c, now + startQuiet(c, now));
    return;
  }
  if (c.state == kWaitTimeout) return sendStartRow(c, 0, now);
  const unsigned row = startRowWaitingIn(c.state);
  if (row == kStartRowCount) return;  // stopped
  const StartRow& r = kStartRows[row];

  const bool ok = !timedOut(c);
  if (!ok && !(r.setupGoesOn && c.mode == Mode::Setup)) {
    if (r.onTimeout == OnTimeout::Retry && !(c.errorLog & cs::kTooManyErrors)) return sendStartRow(c, row, now);
    return restart(c, now);
  }

  switch (r.onReply) {
    case OnReply::Next: break;
    case OnReply::Cookie:
      if (c.reply[0] != lbp::kCookie) {
        setError(c, cs::kInvalidCookie, kCookie);
        return restart(c, now);
      }
      break;
    case OnReply::StatusClear:
      if (c.reply[0] != 0) {
        setError(c, cs::kRemoteFault, kRemFault);
        return restart(c, now);
      }
      break;
    case OnReply::UnitNumber:
      c.ifIn[0] = ok ? littleEndian32(c.reply, 0) : 0;
      c.nameIndex = 0;
      c.ifIn[1] = 0;
      break;
    case OnReply::NameByte:
      c.ifIn[1] |= static_cast<std::uint32_t>(c.reply[0]) << (8 * c.nameIndex);
      ++c.nameIndex;
      break;
    case OnReply::Discovery:
      if (ok) {
        c.rxSize = c.reply[0];
        c.txSize = c.reply[1];
        // Kept in the channel's RAM block, where a host can read them.
        const auto block = local::kChannelBlock + index * local::kChannelBlockStride;
        ram_[block + local::kRxSizeOffset] = c.rxSize;
        ram_[block + local::kTxSizeOffset] = c.txSize;
        c.ifIn[2] = littleEndian32(c.reply, 2);
      }
      if (c.mode == Mode::Setup) {
        // SETUP START: pass-through from here on, no device setup, no chatter.
        c.status = static_cast<std::uint8_t>(c.status & ~(cs::kStatusNotReady | cs::kStatusNoRemoteId |
                                                          cs::kStatusRemoteFault));
        c.ready = true;
        c.startPending = false;
        c.state = kSetupRun;
        checkCommandDone(now);
        return;
      }
      c.status = static_cast<std::uint8_t>(c.status & ~cs::kStatusNoRemoteId);
      break;
    case OnReply::PollUntilZero:
      if (c.reply[0] != 0) return sendStartRow(c, row, now);
      break;
    case OnReply::FaultsClear:
      // A fault byte read here goes to CS byte 3; one that reads 0 leaves
      // CS byte 3 as it was (SSLBP.JMP dochkgenfaults stores only a non-zero
      // byte; SSLBP 43: CS 0x203B0000 while chattering after a normal START
      // whose remote's LowVoltageFault was cleared, 0x20 left from before).
      if (c.reply[0] != 0) {
        c.remoteFault = c.reply[0];
        // Faults that do not clear: report them and keep asking until too many.
        setError(c, cs::kRemoteFault, kRemFault);
        if (c.errorLog & cs::kTooManyErrors) return restart(c, now);
        return sendStartRow(c, row, now);
      }
      c.status = static_cast<std::uint8_t>(c.status & ~cs::kStatusRemoteFault);
      break;
  }

  if (r.next == kBlather) {
    c.state = kBlather;
    schedule(c, now + kPass);
    return;
  }
  sendStartRow(c, startRowWaitingIn(r.next), now);
}

// Chatter (manual: NORMAL START): after a normal START the firmware sends
// zero outputs back to back, keeping the remote's watchdog fed, until the
// first DOIT. The first good reply completes the START; its round trip sets
// the DOIT timeout (docs/protocol-facts.md#sslbp-start-and-timeouts).
void Sslbp::chatter(Channel& c, SimTime now) {
  if (c.state == kBlather) {
    sendProcessData(c, true, kBlatherWait, kNormalStartTimeout, now);
    return;
  }
  // kBlatherWait
  if (c.outcome != Outcome::Ok) {
    setError(c, cs::kTimeout, kTimeoutCount);
    if (c.requested) {
      c.requested = false;  // the request is cancelled; DOIT reports the channel
      checkCommandDone(now);
    }
    c.state = kBlather;
    schedule(c, now + kPass);
    return;
  }
  c.measuredRpc = now - c.sentAt;
  c.status = static_cast<std::uint8_t>(c.status & ~cs::kStatusNotReady);
  if (!c.ready) {
    c.ready = true;
    c.startPending = false;
    checkCommandDone(now);
  }
  if (c.requested) {
    c.state = kRun;
    runNormal(c, now);
    return;
  }
  c.state = kBlather;
  schedule(c, now + kPass);
}

// The normal run (manual: DOIT, CS REGISTER AFTER DOIT, HOST READS INCOMING
// INTERFACE REGISTERS AFTER DOIT): one process data exchange per DOIT
// request, outputs from interface 0..2, the remote's fault byte to CS byte 3.
void Sslbp::runNormal(Channel& c, SimTime now) {
  if (c.state == kRun) {
    if (!c.requested) return;
    sendProcessData(c, false, kRunWait, c.measuredRpc + kTimeoutFudge, now);
    return;
  }
  // kRunWait
  if (!timedOut(c)) {
    c.remoteFault = c.reply[0];
    if (c.remoteFault != 0) {
      // Reported in CS but not counted: the normal run's receive path sets the
      // error without the dead-end counter (SSLBP.JMP dorecvgeneric: setstatus
      // and seterror, no deadendincatX), so a fault held for any number of
      // DOITs never raises TooManyErrors (SSLBP 43: CS 0x20422140 after each
      // of 1100 DOITs with field power off, 0x04422140 with a driver hot).
      c.status = static_cast<std::uint8_t>(c.status | cs::kStatusRemoteFault | cs::kStatusCommunicationError);
      c.errorLog = static_cast<std::uint8_t>(c.errorLog | cs::kRemoteFault);
    }
    // Incoming process data: reply bytes 1.. into interface 0..2.
    for (unsigned r = 0; r < 3; ++r) {
      std::uint32_t v = 0;
      for (unsigned b = 0; b < 4; ++b) {
        const unsigned i = 1 + r * 4 + b;
        if (i < c.rxSize && i < c.reply.size()) v |= static_cast<std::uint32_t>(c.reply[i]) << (8 * b);
      }
      c.ifIn[r] = v;
    }
    c.invalid = false;
  }
  c.requested = false;
  c.state = kRun;
  checkCommandDone(now);
}

// The setup-mode run (manual: SETUP MODE OPERATION, REMOTE READ/WRITE
// EXAMPLE; docs/protocol-facts.md#sslbp-setup-mode): each DOIT passes the
// LBP command the host wrote to CS through to the remote.
void Sslbp::runSetup(Channel& c, SimTime now) {
  if (c.state == kSetupRun) {
    if (!c.requested) return;
    // The LBP command the host wrote to CS: header in byte 3, address in
    // bytes 1..0, write data in interface 0 and 1.
    const auto header = static_cast<std::uint8_t>(c.csOut >> 24);
    if (!(header & 0x40U)) {  // data bytes and RPCs are not passed through
      c.requested = false;
      checkCommandDone(now);
      return;
    }
    std::array<std::uint8_t, 12> f{};
    std::size_t n = 0;
    unsigned expect = 0;
    f[n++] = header;
    if (header < 0xC0) {
      const auto d = lbp::DataCommand::decode(header);
      if (d.hasAddress) {
        f[n++] = static_cast<std::uint8_t>(c.csOut & 0xFFU);
        f[n++] = static_cast<std::uint8_t>((c.csOut >> 8) & 0xFFU);
      }
      if (d.write) {
        for (unsigned i = 0; i < d.dataSize; ++i) f[n++] = static_cast<std::uint8_t>(c.ifOut[i / 4] >> (8 * (i % 4)));
      } else {
        expect = d.dataSize;
      }
    } else if (header & 0x20U) {
      f[n++] = static_cast<std::uint8_t>(c.ifOut[0] & 0xFFU);
    } else {
      expect = 1;
    }
    c.setupExpect = static_cast<std::uint8_t>(expect);
    transact(c, {f.data(), n}, expect, kSetupRunTimeout, kSetupRunWait, now);
    return;
  }
  // kSetupRunWait
  if (c.outcome == Outcome::Ok) {
    if (c.setupExpect > 0) {  // a write's CRC-only reply leaves them alone
      std::array<std::uint8_t, 8> data{};
      std::copy_n(c.reply.begin(), std::min<unsigned>(c.setupExpect, 8), data.begin());
      for (unsigned r = 0; r < 2; ++r) {
        std::uint32_t v = 0;
        for (unsigned b = 0; b < 4; ++b) v |= static_cast<std::uint32_t>(data[r * 4 + b]) << (8 * b);
        c.ifIn[r] = v;
      }
    }
    c.invalid = false;
  } else {
    setError(c, cs::kTimeout, kTimeoutCount);
    // Since SSLBP 40 a setup-mode timeout is flagged in DATA only once
    // errors are too many; the CS error byte always shows it.
    if (!(c.errorLog & cs::kTooManyErrors)) c.invalid = false;
  }
  c.requested = false;
  c.state = kSetupRun;
  checkCommandDone(now);
}

}  // namespace lbpkit::model::hm2
