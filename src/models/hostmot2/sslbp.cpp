#include "hostmot2/sslbp.hpp"

#include <algorithm>

#include "lbp/protocol.hpp"

namespace hm2 {

namespace {

// One pass of the firmware's main loop between steps of a channel.
constexpr SimTime kPass = SimTime{2000};  // 2 us
// START timeouts (firmware: 200 ticks of 2 us normal, 6 ticks of 200 us setup).
constexpr SimTime kNormalStartTimeout = SimTime{400'000};
constexpr SimTime kSetupStartTimeout = SimTime{1'200'000};
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

SmartSerial::SmartSerial(unsigned channels, unsigned instance)
    : instance_(instance), channelCount_(std::min<unsigned>(channels, kMaxChannels)) {
  // initmem: identity and the per-channel baud rates, at power-up only.
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
  globalInit();
}

ModuleDescriptor SmartSerial::descriptor() const {
  // Version 0, 6 registers, instance stride select 1 (0x40), registers 2..5
  // per channel: what LinuxCNC's driver checks for SmartSerial.
  return ModuleDescriptor{tag::kSSerial, 0, kClockLow, 1, kCommand, 6, 0x10, 0x3C};
}

bool SmartSerial::decodes(std::uint16_t address) const {
  if (address < kCommand || address >= kInterface0 + 3 * kRegisterStride) return false;
  return ((address & 0xFFU) / kInstanceStride1) == instance_;
}

// --- Registers -------------------------------------------------------------------

std::uint32_t SmartSerial::csRegister(unsigned channel) const {
  const auto& c = channels_.at(channel);
  return static_cast<std::uint32_t>(c.errorLog) | (static_cast<std::uint32_t>(c.status) << 8) |
         (static_cast<std::uint32_t>(c.state) << 16) | (static_cast<std::uint32_t>(c.remoteFault) << 24);
}

std::uint32_t SmartSerial::read(std::uint16_t address, SimTime now) {
  advance(now);
  const std::uint16_t block = address & 0xFF00U;
  const unsigned ch = (address & 0x3FU) / 4;
  if (block == kCommand) return command_;
  if (block == kData) return dataOut_;
  if (ch >= channelCount_) return 0;
  if (block == kCs) return csRegister(ch);
  return channels_[ch].ifIn[static_cast<unsigned>(block - kInterface0) / kRegisterStride];
}

void SmartSerial::write(std::uint16_t address, std::uint32_t value, SimTime now) {
  advance(now);
  const std::uint16_t block = address & 0xFF00U;
  const unsigned ch = (address & 0x3FU) / 4;
  if (block == kCommand) {
    // COMMAND REGISTER WRITE IGNORE: bit 31 set means "no command" (DMA/TRAM).
    if (value & command::kIgnore) return;
    const auto cmd = static_cast<std::uint16_t>(value & 0xFFFFU);
    ++counters_.commands;
    if (cmd & command::kReset) {
      // M bit: the processor is held in reset until a write without it.
      inReset_ = true;
      command_ = cmd;
      busy_ = Busy::Idle;
      for (unsigned i = 0; i < channelCount_; ++i) initChannel(channels_[i]);
      return;
    }
    if (inReset_) {
      inReset_ = false;
      globalInit();  // the firmware boots, then sees the command
      busy_ = Busy::Idle;
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
        return;
      }
      busy_ = Busy::Idle;
      lost_ = false;
    }
    command_ = cmd;
    execute(cmd, now);
    return;
  }
  if (block == kData) {
    dataIn_ = static_cast<std::uint8_t>(value & 0xFFU);
    return;
  }
  if (ch >= channelCount_) return;
  if (block == kCs)
    channels_[ch].csOut = value;
  else
    channels_[ch].ifOut[static_cast<unsigned>(block - kInterface0) / kRegisterStride] = value;
}

// --- Commands ----------------------------------------------------------------------

void SmartSerial::execute(std::uint16_t cmd, SimTime now) {
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
    }
  } else {
    immediateData_ = 0xFF;  // unknown command
  }
}

void SmartSerial::complete(std::uint8_t data, SimTime) {
  command_ = 0;
  dataOut_ = lost_ ? 0xFF : data;
  lost_ = false;
  busy_ = Busy::Idle;
}

void SmartSerial::globalInit() {
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

void SmartSerial::initChannel(Channel& c) {
  c.mode = Mode::Stopped;
  c.status = 0xC1;
  c.errorLog = 0;
  c.state = 0;
  c.remoteFault = 0;
  c.errorCounts.fill(0);
  c.ready = c.startPending = c.requested = c.invalid = c.doitSeen = c.leftover = false;
  c.scheduled = false;
  c.rxSize = c.txSize = 0;
  // The firmware clears the host-read interface registers but, by a slip in
  // its source, leaves byte 2 of interface 0 alone.
  c.ifIn[0] &= 0x00FF0000U;
  c.ifIn[1] = 0;
  c.ifIn[2] = 0;
}

void SmartSerial::startChannels(std::uint8_t mask, Mode mode, SimTime now) {
  busy_ = Busy::Start;
  commandMask_ = mask;
  for (unsigned i = 0; i < channelCount_; ++i) {
    auto& c = channels_[i];
    if (!(mask & (1U << i)) || c.ready || c.mode != Mode::Stopped) continue;  // START only starts new channels
    c.mode = mode;
    c.errorCounts.fill(0);
    c.startPending = true;
    c.state = kStartTimer;
    schedule(c, now + kPass);
  }
  checkCommandDone(now);
}

void SmartSerial::doit(std::uint8_t mask, SimTime now) {
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

void SmartSerial::checkCommandDone(SimTime now) {
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

void SmartSerial::schedule(Channel& c, SimTime at) {
  c.scheduled = true;
  c.due = at;
}

void SmartSerial::advance(SimTime now) {
  // Events in time order; at equal times a finishing command goes first.
  for (;;) {
    SimTime at = now;
    int which = -2;  // -1: the running immediate command; >= 0: a channel
    if (busy_ == Busy::Immediate && immediateDone_ <= at) {
      at = immediateDone_;
      which = -1;
    }
    for (unsigned i = 0; i < channelCount_; ++i) {
      const auto& c = channels_[i];
      if (c.scheduled && c.due <= now && (which == -2 || c.due < at)) {
        at = c.due;
        which = static_cast<int>(i);
      }
    }
    if (which == -2) break;
    if (which == -1) {
      complete(immediateData_, at);
    } else {
      channels_[static_cast<unsigned>(which)].scheduled = false;
      step(static_cast<unsigned>(which), at);
    }
  }
}

SimTime SmartSerial::startTimeout(const Channel& c) const {
  return c.mode == Mode::Setup ? kSetupStartTimeout : kNormalStartTimeout;
}

void SmartSerial::setError(Channel& c, std::uint8_t bit, unsigned counter) {
  c.errorLog = static_cast<std::uint8_t>(c.errorLog | bit);
  c.status = static_cast<std::uint8_t>(c.status | cs::kStatusCommunicationError);
  if (c.errorCounts[counter] < kMaxErrors)
    ++c.errorCounts[counter];
  else
    c.errorLog = static_cast<std::uint8_t>(c.errorLog | cs::kTooManyErrors);
}

void SmartSerial::restart(Channel& c, SimTime now) {
  if (c.errorLog & cs::kTooManyErrors) {
    // The channel has failed: START completes without it.
    c.startPending = false;
    checkCommandDone(now);
    return;
  }
  c.state = kStartTimer;
  schedule(c, now + kPass);
}

void SmartSerial::transact(Channel& c, std::span<const std::uint8_t> body, unsigned expect, SimTime timeout,
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
  const std::size_t need = expect + 1;
  const SimTime ch = lbp::characterTime(c.baud);
  c.outcome = Outcome::Timeout;
  SimTime due = now + timeout;
  if (reply.size >= need) {
    const SimTime arrival = reply.lastByteAt - ch * static_cast<std::int64_t>(reply.size - need);
    if (reply.breakSeen) {
      setError(c, cs::kSerialBreak, kBreak);  // the reply is discarded
      c.outcome = Outcome::Break;
    } else if (arrival > now + timeout) {
      c.leftover = true;  // too late: it lands in the FIFO after the timeout
    } else if (lbp::crc8({reply.bytes.data(), need}) != 0) {
      setError(c, cs::kCrcError, kCrc);  // discarded; the channel then times out
      c.outcome = Outcome::CrcError;
    } else {
      c.outcome = Outcome::Ok;
      std::copy_n(reply.bytes.begin(), std::min(expect, static_cast<unsigned>(c.reply.size())), c.reply.begin());
      c.leftover = reply.size > need;
      due = std::max(arrival, now) + kPass;
    }
  } else if (reply.size > 0) {
    c.leftover = true;  // a partial reply stays in the FIFO
  }
  schedule(c, due);
}

// --- The per-channel state machine (SSLBP.JMP's "dochannel") -----------------------

void SmartSerial::step(unsigned index, SimTime now) {
  Channel& c = channels_[index];
  const bool ok = c.outcome == Outcome::Ok;
  auto send = [&](std::initializer_list<std::uint8_t> frame, unsigned expect, std::uint8_t wait,
                  SimTime timeout = SimTime{0}) {
    transact(c, std::span<const std::uint8_t>(frame.begin(), frame.size()), expect,
             timeout.count() ? timeout : startTimeout(c), wait, now);
  };
  auto sendProcessData = [&](bool zeros, std::uint8_t wait, SimTime timeout) {
    std::array<std::uint8_t, 13> f{};
    f[0] = lbp::special_rpc::kProcessData;
    for (unsigned i = 0; i < c.txSize && i < 12; ++i)
      f[1 + i] = zeros ? std::uint8_t{0} : static_cast<std::uint8_t>(c.ifOut[i / 4] >> (8 * (i % 4)));
    transact(c, {f.data(), 1U + std::min<unsigned>(c.txSize, 12)}, c.rxSize, timeout, wait, now);
  };
  auto timedOut = [&]() {
    if (!ok) setError(c, cs::kTimeout, kTimeoutCount);
    return !ok;
  };

  switch (c.state) {
    case kStartTimer:
      // Stay silent for a start timeout so the remote's parser resets.
      c.state = kWaitTimeout;
      schedule(c, now + startTimeout(c));
      return;
    case kWaitTimeout:
      send({lbp::local_read::kCookie}, 1, kCookieWait);
      return;
    case kCookieWait:
      if (timedOut()) return restart(c, now);
      if (c.reply[0] != lbp::kCookie) {
        setError(c, cs::kInvalidCookie, kCookie);
        return restart(c, now);
      }
      send({lbp::local_write::kCommandTimeout, kLbpCharTimeout}, 0, kCharTimeoutWait);
      return;
    case kCharTimeoutWait:
      if (timedOut()) return restart(c, now);
      send({lbp::local_write::kStatus, 0x00}, 0, kClearStatusWait);
      return;
    case kClearStatusWait:
      if (timedOut()) return restart(c, now);
      send({lbp::local_read::kStatus}, 1, kReadStatusWait);
      return;
    case kReadStatusWait:
      if (timedOut()) return restart(c, now);
      if (c.reply[0] != 0) {
        setError(c, cs::kRemoteFault, kRemFault);
        return restart(c, now);
      }
      send({lbp::special_rpc::kUnitNumber}, 4, kUnitWait);
      return;
    case kUnitWait:
      if (timedOut() && c.mode == Mode::Normal) {
        // Normal start insists on a unit number; every miss counts.
        if (c.errorLog & cs::kTooManyErrors) return restart(c, now);
        send({lbp::special_rpc::kUnitNumber}, 4, kUnitWait);
        return;
      }
      c.ifIn[0] = ok ? (static_cast<std::uint32_t>(c.reply[0]) | (static_cast<std::uint32_t>(c.reply[1]) << 8) |
                        (static_cast<std::uint32_t>(c.reply[2]) << 16) | (static_cast<std::uint32_t>(c.reply[3]) << 24))
                     : 0;
      c.nameIndex = 0;
      c.ifIn[1] = 0;
      send({lbp::local_read::kCardName0}, 1, kNameWait);
      return;
    case kNameWait:
    case kNameWait + 2:
    case kNameWait + 4:
    case kNameWait + 6:
      if (timedOut()) return restart(c, now);
      c.ifIn[1] |= static_cast<std::uint32_t>(c.reply[0]) << (8 * c.nameIndex);
      if (++c.nameIndex < 4) {
        send({static_cast<std::uint8_t>(lbp::local_read::kCardName0 + c.nameIndex)}, 1,
             static_cast<std::uint8_t>(kNameWait + 2 * c.nameIndex));
        return;
      }
      // Not an 8I20 or 7I64 (those have hard-wired paths): the generic path.
      // The remote's software mode is the top byte the host wrote to CS.
      send({lbp::local_write::kRemoteSwMode, static_cast<std::uint8_t>(c.csOut >> 24)}, 0, kSetModeWait);
      return;
    case kSetModeWait:
      if (timedOut()) return restart(c, now);
      send({lbp::special_rpc::kDiscovery}, 6, kDiscoveryWait);
      return;
    case kDiscoveryWait:
      if (timedOut() && c.mode == Mode::Normal) return restart(c, now);
      if (ok) {
        c.rxSize = c.reply[0];
        c.txSize = c.reply[1];
        // Kept in the channel's RAM block, where a host can read them.
        const auto block = local::kChannelBlock + index * local::kChannelBlockStride;
        ram_[block + local::kRxSizeOffset] = c.rxSize;
        ram_[block + local::kTxSizeOffset] = c.txSize;
        c.ifIn[2] = static_cast<std::uint32_t>(c.reply[2]) | (static_cast<std::uint32_t>(c.reply[3]) << 8) |
                    (static_cast<std::uint32_t>(c.reply[4]) << 16) | (static_cast<std::uint32_t>(c.reply[5]) << 24);
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
      sendProcessData(true, kClearOutputsWait, startTimeout(c));  // outputs off
      return;
    case kClearOutputsWait:
      if (timedOut()) {
        if (c.errorLog & cs::kTooManyErrors) return restart(c, now);
        sendProcessData(true, kClearOutputsWait, startTimeout(c));
        return;
      }
      send({lbp::local_write::kClearFault, 0xFF}, 0, kSetClearFaultWait);
      return;
    case kSetClearFaultWait:
      if (timedOut()) return restart(c, now);
      send({lbp::local_read::kClearFault}, 1, kPollClearFaultWait);
      return;
    case kPollClearFaultWait:
      if (timedOut()) return restart(c, now);
      if (c.reply[0] != 0) {
        send({lbp::local_read::kClearFault}, 1, kPollClearFaultWait);
        return;
      }
      send({lbp::local_read::kFaultStatus}, 1, kReadFaultWait);
      return;
    case kReadFaultWait:
      if (timedOut()) return restart(c, now);
      if (c.reply[0] != 0) {
        // Faults that do not clear: report them and keep asking until too many.
        c.remoteFault = c.reply[0];
        setError(c, cs::kRemoteFault, kRemFault);
        if (c.errorLog & cs::kTooManyErrors) return restart(c, now);
        send({lbp::local_read::kFaultStatus}, 1, kReadFaultWait);
        return;
      }
      c.status = static_cast<std::uint8_t>(c.status & ~cs::kStatusRemoteFault);
      c.state = kBlather;
      schedule(c, now + kPass);
      return;
    case kBlather:
      // The "chatter" loop: zero outputs back to back to feed the remote's
      // watchdog until the first DOIT (manual: NORMAL START).
      sendProcessData(true, kBlatherWait, kNormalStartTimeout);
      return;
    case kBlatherWait:
      if (!ok) {
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
        step(index, now);
        return;
      }
      c.state = kBlather;
      schedule(c, now + kPass);
      return;
    case kRun:
      if (!c.requested) return;
      sendProcessData(false, kRunWait, c.measuredRpc + kTimeoutFudge);
      return;
    case kRunWait:
      if (!timedOut()) {
        c.remoteFault = c.reply[0];
        if (c.remoteFault != 0) {
          c.status = static_cast<std::uint8_t>(c.status | cs::kStatusRemoteFault);
          setError(c, cs::kRemoteFault, kRemFault);
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
      return;
    case kSetupRun: {
      if (!c.requested) return;
      // The LBP command the host wrote to CS: header in byte 3, address in
      // bytes 1..0, write data in interface 0 and 1 (manual: SETUP MODE OPERATION).
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
    case kSetupRunWait:
      if (ok) {
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
      return;
    default:
      return;
  }
}

}  // namespace hm2
