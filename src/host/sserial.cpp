// SPDX-License-Identifier: MIT
#include "lbpkit/sserial.hpp"

#include "lbpkit/servo_cycle.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cctype>

#include "lbpkit/wire/hostmot2.hpp"
#include "lbpkit/wire/lbp.hpp"
#include "lbpkit/wire/process_data.hpp"
#include "lbpkit/wire/seven_i77.hpp"
#include "lbpkit/wire/sslbp.hpp"
#include "lbpkit/error.hpp"
#include "lbpkit/faults.hpp"
#include "lbpkit/wire/names.hpp"

namespace lbpkit {

namespace {
using namespace wire::sslbp::command;
namespace local = wire::sslbp::local;

// LBP through SSLBP setup mode: the command header in CS byte 3, the
// address in bytes 1..0, data in interface 0/1; one DOIT per command
// (manual: SETUP MODE OPERATION). Each DOIT is one write exchange and one
// read exchange (more only while the DOIT is still running).
class SetupChannelAccess final : public RemoteAccess {
 public:
  SetupChannelAccess(Transport& t, const SmartSerialRegisters& regs, unsigned channel, Nanoseconds timeout,
                     Nanoseconds poll)
      : t_(t), regs_(regs), channel_(channel), timeout_(timeout), poll_(poll) {
    // The CS error byte as START left it: a setup START counts the special
    // RPCs a remote running only its boot block does not answer (unit
    // number, discovery) as timeouts and goes on (manual: SETUP START;
    // docs/protocol-facts.md#sslbp-start-and-timeouts). Only errors after
    // this are a command's.
    std::uint32_t cs = 0;
    t_.queueRead(regs_.cs(channel_), &cs);
    t_.flush();
    lastErrors_ = static_cast<std::uint8_t>(cs);
  }

  std::uint64_t read(std::uint16_t address, unsigned size) override {
    const std::uint8_t header = wire::lbp::readHeader(static_cast<std::uint8_t>(size), true);
    return run(header, address, 0, true, fmt::format("read of {} bytes at 0x{:04X}", size, address));
  }
  void write(std::uint16_t address, unsigned size, std::uint64_t value) override {
    const std::uint8_t header = wire::lbp::writeHeader(static_cast<std::uint8_t>(size), true);
    run(header, address, value, false, fmt::format("write of {} bytes at 0x{:04X}", size, address));
  }
  std::uint8_t localRead(std::uint8_t command) override {
    return static_cast<std::uint8_t>(run(command, 0, 0, true, fmt::format("local read 0x{:02X}", command)));
  }
  void localWrite(std::uint8_t command, std::uint8_t value) override {
    run(command, 0, value, false, fmt::format("local write 0x{:02X}", command));
  }
  [[nodiscard]] std::uint64_t transactions() const override { return transactions_; }
  [[nodiscard]] std::string where() const override { return fmt::format("channel {}", channel_); }

 private:
  std::uint64_t run(std::uint8_t header, std::uint16_t address, std::uint64_t data, bool read,
                    const std::string& what) {
    const std::uint32_t words[2] = {static_cast<std::uint32_t>(data), static_cast<std::uint32_t>(data >> 32)};
    const std::uint32_t cs = (static_cast<std::uint32_t>(header) << wire::sslbp::cs::kRemoteByteShift) | address;
    const std::uint32_t doit = kDoit | (1U << channel_);
    if (!read) {
      t_.queueWrite(regs_.interface(0, channel_), &words[0]);
      t_.queueWrite(regs_.interface(1, channel_), &words[1]);
    }
    t_.queueWrite(regs_.cs(channel_), &cs);
    t_.queueWrite(regs_.command(), &doit);
    t_.flush();
    ++transactions_;
    const Nanoseconds start = t_.now();
    std::uint32_t cmd = 0, dataReg = 0, csNow = 0, in[2] = {};
    for (;;) {
      t_.queueRead(regs_.command(), &cmd);
      t_.queueRead(regs_.data(), &dataReg);
      t_.queueRead(regs_.cs(channel_), &csNow);
      t_.queueRead(regs_.interface(0, channel_), &in[0]);
      t_.queueRead(regs_.interface(1, channel_), &in[1]);
      t_.flush();
      if (cmd == 0) break;
      if (t_.now() - start > timeout_)
        throw Error(fmt::format("channel {}: {} never completed (COMMAND still 0x{:04X})", channel_, what, cmd));
      t_.sleep(poll_);
    }
    // In setup mode SSLBP flags a failed request in DATA only once errors are
    // too many; a new bit in the CS error byte shows it at once.
    const auto newErrors = static_cast<std::uint8_t>(csNow & ~lastErrors_ & 0xFFU);
    lastErrors_ = static_cast<std::uint8_t>(csNow);
    if ((dataReg & (1U << channel_)) || newErrors)
      throw Error(fmt::format("channel {}: remote {} failed: {}", channel_, what, describeCs(csNow)));
    return in[0] | (static_cast<std::uint64_t>(in[1]) << 32);
  }

  Transport& t_;
  const SmartSerialRegisters& regs_;
  unsigned channel_;
  Nanoseconds timeout_;
  Nanoseconds poll_;
  std::uint64_t transactions_ = 0;
  std::uint8_t lastErrors_ = 0;
};

}  // namespace

SmartSerialRegisters::SmartSerialRegisters(const ModuleInfo& md, unsigned instance)
    : command_(static_cast<std::uint16_t>(md.baseAddress + instance * md.instanceStride)),
      data_(static_cast<std::uint16_t>(command_ + wire::sslbp::reg::kData * md.registerStride)),
      cs_(static_cast<std::uint16_t>(md.baseAddress + wire::sslbp::reg::kCs * md.registerStride +
                                     instance * md.instanceStride)),
      stride_(md.registerStride) {}

std::string ChannelIdentity::function() const {
  namespace type = wire::i7i77::unit_type;
  if (name != wire::i7i77::kCardName) return {};
  switch (unitNumber >> type::kShift) {
    case type::kFieldIo: return "field I/O";
    case type::kAnalog: return "analog";
    default: return {};
  }
}

static const ModuleInfo& sserialModule(const CardInfo& card) {
  const ModuleInfo* md = card.module(wire::hm2::tag::kSSerial);
  if (md == nullptr)
    throw Error(fmt::format("the card ({}) has no SSerial module: its firmware has no smart-serial interface",
                            card.boardName));
  return *md;
}

SmartSerial::SmartSerial(Transport& t, const CardInfo& card, Options options)
    : t_(t), options_(options), regs_(sserialModule(card), options.instance), channels_(card.sserialChannels()) {
  if (channels_ == 0) channels_ = 8;
}

SmartSerial::~SmartSerial() = default;

std::uint8_t SmartSerial::waitCommand() {
  const Nanoseconds start = t_.now();
  for (;;) {
    t_.queueRead(regs_.command(), &pollCommand_);
    t_.queueRead(regs_.data(), &pollData_);
    t_.flush();
    if (pollCommand_ == 0) return static_cast<std::uint8_t>(pollData_);
    if (t_.now() - start > options_.commandTimeout)
      throw Error(fmt::format("SSLBP command 0x{:04X} did not complete within {} ms", pollCommand_,
                              options_.commandTimeout.count() / 1'000'000));
    t_.sleep(options_.pollInterval);
  }
}

std::uint8_t SmartSerial::command(std::uint16_t cmd) {
  // Never write COMMAND while it is busy (manual: COMMAND REGISTER), except a stop.
  if ((cmd & kTypeMask) != kStop) waitCommand();
  const std::uint32_t v = cmd;
  t_.queueWrite(regs_.command(), &v);
  t_.flush();
  if (cmd & kDoit) ++doits_;
  return waitCommand();
}

std::uint8_t SmartSerial::localRead(std::uint16_t address) { return command(static_cast<std::uint16_t>(kRequest | address)); }

void SmartSerial::localWrite(std::uint16_t address, std::uint8_t value) {
  const std::uint32_t v = value;
  waitCommand();
  t_.queueWrite(regs_.data(), &v);
  t_.flush();
  command(static_cast<std::uint16_t>(kWrite | kRequest | address));
}

std::uint8_t SmartSerial::stopAll() { return command(kStop); }

namespace {
// Where a channel's baud rate is among SSLBP's local parameters.
std::uint16_t baudAddress(SmartSerial& ss, unsigned channel) {
  if (channel >= ss.channels()) throw Error("no smart-serial channel " + std::to_string(channel) + " on this card");
  return static_cast<std::uint16_t>(ss.localRead(local::kChannelStart) + channel * ss.localRead(local::kChannelStride) +
                                    local::kBaudOffset);
}
}  // namespace

void SmartSerial::setBaudRate(unsigned channel, std::uint32_t baud) {
  const std::uint16_t at = baudAddress(*this, channel);
  for (unsigned i = 0; i < 4; ++i) localWrite(static_cast<std::uint16_t>(at + i), static_cast<std::uint8_t>(baud >> (8 * i)));
}

std::uint32_t SmartSerial::baudRate(unsigned channel) {
  const std::uint16_t at = baudAddress(*this, channel);
  std::uint32_t baud = 0;
  for (unsigned i = 0; i < 4; ++i) baud |= std::uint32_t{localRead(static_cast<std::uint16_t>(at + i))} << (8 * i);
  return baud;
}

std::uint8_t SmartSerial::start(std::uint8_t mask, bool setup) {
  mask = static_cast<std::uint8_t>(mask & options_.channelMask & ((1U << channels_) - 1));
  for (unsigned ch = 0; ch < channels_; ++ch) {
    if (!(mask & (1U << ch))) continue;
    const std::uint32_t cs = static_cast<std::uint32_t>(options_.modes[ch]) << wire::sslbp::cs::kRemoteByteShift;  // REMOTE MODES
    t_.queueWrite(regs_.cs(ch), &cs);
  }
  t_.flush();
  return static_cast<std::uint8_t>(command(static_cast<std::uint16_t>((setup ? kSetupStart : kStart) | mask)) & mask);
}

ChannelIdentity SmartSerial::identity(unsigned channel) {
  std::uint32_t v[4] = {};
  t_.queueRead(regs_.interface(0, channel), &v[0]);
  t_.queueRead(regs_.interface(1, channel), &v[1]);
  t_.queueRead(regs_.interface(2, channel), &v[2]);
  t_.queueRead(regs_.cs(channel), &v[3]);
  t_.flush();
  ChannelIdentity id;
  id.channel = channel;
  id.unitNumber = v[0];
  for (int i = 0; i < 4; ++i) {
    const char c = static_cast<char>(v[1] >> (8 * i));
    if (c) id.name.push_back(c);
  }
  id.ptoc = static_cast<std::uint16_t>(v[2]);
  id.gtoc = static_cast<std::uint16_t>(v[2] >> 16);
  id.cs = v[3];
  id.present = id.ptoc != 0;  // as LinuxCNC decides
  return id;
}

std::unique_ptr<RemoteAccess> SmartSerial::remote(unsigned channel) {
  return std::make_unique<SetupChannelAccess>(t_, regs_, channel, options_.commandTimeout, options_.pollInterval);
}

std::vector<ChannelIdentity> SmartSerial::discover(std::uint8_t mask) {
  const Nanoseconds t0 = t_.now();
  slots_.clear();
  discoveryStats_ = {};
  const std::uint64_t doitsBefore = doits_;
  stopAll();
  const std::uint8_t failed = start(mask, true);
  std::vector<ChannelIdentity> found;
  const unsigned chStart = localRead(local::kChannelStart);
  const unsigned chStride = localRead(local::kChannelStride);
  for (unsigned ch = 0; ch < channels_; ++ch) {
    if (!(mask & options_.channelMask & (1U << ch))) continue;
    ChannelIdentity id = identity(ch);
    if (failed & (1U << ch)) id.present = false;
    found.push_back(id);
    if (!id.present) continue;
    // The discovery RPC's sizes, as SSLBP stored them in its channel block.
    const auto block = static_cast<std::uint16_t>(chStart + ch * chStride);
    const unsigned rx = localRead(static_cast<std::uint16_t>(block + local::kRxSizeOffset));
    const unsigned tx = localRead(static_cast<std::uint16_t>(block + local::kTxSizeOffset));
    auto access = remote(ch);
    Slot s;
    s.identity = id;
    s.description = lbpkit::discover(*access, id.ptoc, id.gtoc, rx ? std::optional<unsigned>(rx) : std::nullopt,
                                     rx ? std::optional<unsigned>(tx) : std::nullopt);
    discoveryStats_.doits += access->transactions();
    slots_.push_back(std::move(s));
  }
  discoveryStats_.doits += doits_ - doitsBefore;
  discoveryStats_.time = t_.now() - t0;
  return found;
}

std::uint8_t SmartSerial::runningMask() const {
  std::uint8_t m = 0;
  for (const auto& s : slots_) m = static_cast<std::uint8_t>(m | (1U << s.identity.channel));
  return m;
}

void SmartSerial::startNormal() {
  if (slots_.empty()) throw Error("no smart-serial remotes discovered: nothing to start");
  stopAll();
  const std::uint8_t failed = start(runningMask(), false);
  if (failed) {
    std::string why;
    for (unsigned ch = 0; ch < channels_; ++ch) {
      if (!(failed & (1U << ch))) continue;
      std::uint32_t cs = 0;
      t_.queueRead(regs_.cs(ch), &cs);
      t_.flush();
      why += fmt::format(" channel {}: {};", ch, describeCs(cs));
    }
    throw Error("smart-serial channels failed to start:" + why + " check cabling, field power and remote faults");
  }
  for (auto& s : slots_) {
    const auto& pd = s.description.processData;
    s.raw.assign(pd.size(), 0);
    s.inOffset.assign(pd.size(), 0);
    s.outOffset.assign(pd.size(), 0);
    unsigned in = 0, out = 0;
    for (std::size_t i = 0; i < pd.size(); ++i) {
      if (pd[i].fromRemote()) {
        s.inOffset[i] = in;
        in += pd[i].bits;
      }
      if (pd[i].toRemote()) {
        s.outOffset[i] = out;
        out += pd[i].bits;
      }
    }
    s.inRegs = (in + 31) / 32;
    s.outRegs = (out + 31) / 32;
    s.ifIn = {};
    s.ifOut = {};
    s.faultCount = 0;
    s.running = true;
  }
  doitWord_ = kDoit | runningMask();
}

ElementRef SmartSerial::find(unsigned channel, const std::string& name) const {
  const std::string want = wire::asciiLower(name);
  for (std::size_t s = 0; s < slots_.size(); ++s) {
    if (slots_[s].identity.channel != channel) continue;
    const auto& pd = slots_[s].description.processData;
    for (std::size_t i = 0; i < pd.size(); ++i)
      if (wire::asciiLower(pd[i].name) == want) return ElementRef{static_cast<std::uint8_t>(s), static_cast<std::uint8_t>(i)};
  }
  return {};
}

void SmartSerial::set(ElementRef e, double value) {
  auto& s = slots_.at(e.slot);
  s.raw.at(e.element) = s.description.processData[e.element].unscale(value);
}
void SmartSerial::setRaw(ElementRef e, std::uint64_t raw) { slots_.at(e.slot).raw.at(e.element) = raw; }
void SmartSerial::setBit(ElementRef e, unsigned bit, bool on) {
  auto& r = slots_.at(e.slot).raw.at(e.element);
  r = on ? (r | (1ULL << bit)) : (r & ~(1ULL << bit));
}
double SmartSerial::value(ElementRef e) const {
  const auto& s = slots_.at(e.slot);
  return s.description.processData[e.element].scale(s.raw.at(e.element));
}
std::uint64_t SmartSerial::raw(ElementRef e) const { return slots_.at(e.slot).raw.at(e.element); }

void SmartSerial::queueOutputs() {
  for (auto& s : slots_) {
    // PROCESS ELEMENT PACKING: PTOC order, LSB first across interface 0..2,
    // in a buffer with room past the 12 bytes so every element is one word.
    std::array<std::uint8_t, 12 + wire::lbp::kPackingRoom> bytes{};
    const auto& pd = s.description.processData;
    for (std::size_t i = 0; i < pd.size(); ++i)
      if (pd[i].toRemote()) wire::lbp::packBits(bytes, s.outOffset[i], pd[i].bits, s.raw[i]);
    for (unsigned r = 0; r < 3; ++r)
      s.ifOut[r] = std::uint32_t{bytes[4 * r]} | (std::uint32_t{bytes[4 * r + 1]} << 8) |
                   (std::uint32_t{bytes[4 * r + 2]} << 16) | (std::uint32_t{bytes[4 * r + 3]} << 24);
    for (unsigned r = 0; r < s.outRegs; ++r) t_.queueWrite(regs_.interface(r, s.identity.channel), &s.ifOut[r]);
  }
  t_.queueWrite(regs_.command(), &doitWord_);
  ++doits_;
  // The caller flushes these; collectInputs() learns from the counters
  // whether that exchange failed.
  failuresAtQueue_ = t_.linkCounters().failedExchanges();
}

CycleStatus SmartSerial::collectInputs() {
  CycleStatus st;
  // Did the exchange that carried the outputs and the DOIT fail?
  st.replyLost = t_.linkCounters().failedExchanges() != failuresAtQueue_;
  const Nanoseconds start = t_.now();
  // Over a network every poll is a round trip: first wait about as long as
  // the last DOIT that a first poll found busy took to finish (an upper
  // bound, within a poll interval). Each time the first poll already finds
  // it done the wait shrinks by 1/32, so it follows a DOIT that got
  // shorter while a first poll finds COMMAND busy only once in tens of
  // cycles (a wait halved at each done poll would alternate: two polls
  // every other cycle).
  if (busyEstimate_.count() > 0) t_.sleep(busyEstimate_);
  bool sawBusy = false;
  for (;;) {
    t_.queueRead(regs_.command(), &pollCommand_);
    t_.queueRead(regs_.data(), &pollData_);
    for (auto& s : slots_) {
      t_.queueRead(regs_.cs(s.identity.channel), &s.cs);
      for (unsigned r = 0; r < s.inRegs; ++r) t_.queueRead(regs_.interface(r, s.identity.channel), &s.ifIn[r]);
    }
    if (!t_.tryFlush()) {
      // No retry: the timeout took this cycle's time. The next cycle polls
      // again (a late reply to this one is discarded by the transport).
      st.ok = false;
      st.replyLost = true;
      ++lostCycles_;
      return st;
    }
    if (pollCommand_ == 0) break;
    sawBusy = true;
    if (t_.now() - start > options_.commandTimeout) {
      st.ok = false;
      st.commandBusy = true;
      if (st.replyLost) ++lostCycles_;
      countFaults(st);
      return st;
    }
    t_.sleep(options_.pollInterval);
  }
  st.doitTime = t_.now() - start;
  busyEstimate_ = sawBusy ? std::min(st.doitTime, kMaxBusyEstimate) : busyEstimate_ - busyEstimate_ / 32;
  st.failedMask = static_cast<std::uint8_t>(pollData_);
  if (st.replyLost) ++lostCycles_;
  st.ok = st.failedMask == 0 && !st.replyLost;
  for (auto& s : slots_) {
    const auto bit = static_cast<std::uint8_t>(1U << s.identity.channel);
    if (st.failedMask & bit) continue;  // stale data: keep the last inputs
    // Not running (its START failed): DOIT does not ask it, DATA does not
    // flag it, and its interface registers hold what START left there.
    if ((s.cs >> 8) & wire::sslbp::cs::kStatusNotReady) {
      st.ok = false;
      continue;
    }
    st.freshMask = static_cast<std::uint8_t>(st.freshMask | bit);
    std::array<std::uint8_t, 12 + wire::lbp::kPackingRoom> bytes{};  // room past the end, as above
    for (unsigned r = 0; r < 3; ++r)
      for (unsigned b = 0; b < 4; ++b) bytes[4 * r + b] = static_cast<std::uint8_t>(s.ifIn[r] >> (8 * b));
    const auto& pd = s.description.processData;
    for (std::size_t i = 0; i < pd.size(); ++i)
      if (pd[i].direction != Direction::Output) s.raw[i] = wire::lbp::unpackBits(bytes, s.inOffset[i], pd[i].bits);
  }
  ++cycles_;
  countFaults(st);
  return st;
}

void SmartSerial::countFaults(CycleStatus& st) {
  // LinuxCNC's rule (hostmot2 sserial: fault-inc, fault-dec, fault-lim), per
  // channel: a failed DOIT adds the increment, every cycle takes off the
  // decrement. A cycle whose COMMAND never cleared fails every channel; a
  // cycle whose reply was lost is the transport's error, not the link's, and
  // is not counted (its DATA and CS are not known).
  if (st.replyLost) return;
  std::uint8_t due = 0;  // slots autoRecover restarts
  for (std::size_t i = 0; i < slots_.size(); ++i) {
    auto& s = slots_[i];
    const auto bit = static_cast<std::uint8_t>(1U << s.identity.channel);
    if (st.commandBusy || !(st.freshMask & bit)) s.faultCount += options_.faultIncrement;
    s.faultCount = s.faultCount > options_.faultDecrement ? s.faultCount - options_.faultDecrement : 0;
    if (s.faultCount > options_.faultLimit) st.overLimitMask = static_cast<std::uint8_t>(st.overLimitMask | bit);
    if (!st.commandBusy && (s.cs & wire::sslbp::cs::kTooManyErrors))
      st.tooManyErrorsMask = static_cast<std::uint8_t>(st.tooManyErrorsMask | bit);
    if (!options_.autoRecover || !(st.needsRecovery() & bit)) continue;
    if (s.lastRecovery.count() >= 0 && t_.now() - s.lastRecovery < options_.recoveryInterval) continue;
    due = static_cast<std::uint8_t>(due | (1U << i));
  }
  if (due == 0 || st.commandBusy) return;
  try {
    restart(due);
    for (std::size_t i = 0; i < slots_.size(); ++i)
      if (due & (1U << i))
        st.recoveredMask = static_cast<std::uint8_t>(st.recoveredMask | (1U << slots_[i].identity.channel));
  } catch (const Error&) {
    st.recoveryFailed = true;  // the card did not answer: the next cycle tries again
  }
}

CycleStatus SmartSerial::cycle() { return servoCycle(t_, *this, nullptr); }

bool SmartSerial::recover(unsigned slot) {
  auto& s = slots_.at(slot);
  if (s.lastRecovery.count() >= 0 && t_.now() - s.lastRecovery < options_.recoveryInterval) return false;
  restart(static_cast<std::uint8_t>(1U << slot));
  return true;
}

std::uint8_t SmartSerial::restart(std::uint8_t slotMask) {
  const Nanoseconds now = t_.now();
  std::uint8_t channels = 0;
  for (std::size_t i = 0; i < slots_.size(); ++i) {
    if (!(slotMask & (1U << i))) continue;
    auto& s = slots_[i];
    s.lastRecovery = now;
    s.faultCount = 0;
    ++s.recoveries;
    s.running = false;
    const auto bit = static_cast<std::uint8_t>(1U << s.identity.channel);
    channels = static_cast<std::uint8_t>(channels | bit);
    command(static_cast<std::uint16_t>(kStop | bit));  // individual stop: error recovery
  }
  // One START for them all: the channels start side by side.
  const std::uint8_t failed = start(channels, false);
  for (std::size_t i = 0; i < slots_.size(); ++i)
    if (slotMask & (1U << i)) slots_[i].running = !(failed & (1U << slots_[i].identity.channel));
  return failed;
}

}  // namespace lbpkit
