// SPDX-License-Identifier: MIT
#include "lbpkit/encoders.hpp"

#include <fmt/format.h>

#include <cmath>

#include "lbpkit/error.hpp"
#include "lbpkit/wire/hostmot2.hpp"
#include "lbpkit/wire/muxed_encoder.hpp"

namespace lbpkit {

namespace {
using wire::qcount::ccr::kFilter;
using wire::qcount::ccr::kJustOnce;
using wire::qcount::ccr::kLatchOnIndex;
}  // namespace

MuxedEncoders::MuxedEncoders(Transport& t, const CardInfo& card, unsigned used) : t_(t) {
  const ModuleInfo* md = card.module(wire::hm2::tag::kMuxedQCount);
  if (md == nullptr) throw Error(fmt::format("the card ({}) has no muxed encoder module", card.boardName));
  base_ = md->baseAddress;
  regStride_ = md->registerStride;
  instanceStride_ = md->instanceStride;
  clock_ = md->clockHz;
  count_ = std::min<unsigned>(md->instances, kMax);
  if (used != kAll) {
    if (used > count_)
      throw Error(fmt::format("{} muxed encoders asked for; the card ({}) has {}", used, card.boardName, count_));
    count_ = used;
  }
  tsDivisor_ = clock_ / 2'000'000 - 2;  // 2 MHz timestamps
}

std::uint16_t MuxedEncoders::reg(unsigned block, unsigned counter) const {
  return static_cast<std::uint16_t>(base_ + block * regStride_ + instanceStride_ * counter);
}

void MuxedEncoders::initialize() {
  for (unsigned n = 0; n < count_; ++n) {
    state_[n].controlOut = kFilter;
    t_.queueWrite(reg(wire::qcount::reg::kControl, n), &state_[n].controlOut);
  }
  const std::uint32_t rate = clock_ / 8'000'000 - 2;  // 8 MHz mux ticks: 2 MHz count rate
  t_.queueWrite(reg(wire::qcount::reg::kTimestampDiv, 0), &tsDivisor_);
  t_.queueWrite(reg(wire::qcount::reg::kRate, 0), &rate);
  t_.flush();
}

void MuxedEncoders::enableIndex(unsigned n) {
  auto& s = state_.at(n);
  s.indexArmed = true;
  s.controlOut = kFilter | kJustOnce | kLatchOnIndex;
  s.writeControl = true;
}

void MuxedEncoders::queue() {
  for (unsigned n = 0; n < count_; ++n) {
    auto& s = state_[n];
    if (s.writeControl) {
      t_.queueWrite(reg(wire::qcount::reg::kControl, n), &s.controlOut);
      s.writeControl = false;
      s.controlQueued = true;
    }
  }
  t_.queueRead(reg(wire::qcount::reg::kTimestamp, 0), &timestamp_);
  for (unsigned n = 0; n < count_; ++n) {
    t_.queueRead(reg(wire::qcount::reg::kCount, n), &state_[n].countReg);
    t_.queueRead(reg(wire::qcount::reg::kControl, n), &state_[n].ccr);
  }
  failuresAtQueue_ = t_.linkCounters().failedExchanges();
}

bool MuxedEncoders::update() {
  // A failure since queue() may have been these reads' exchange (or another
  // one of the cycle: skipping a fresh update costs nothing but a cycle's
  // delay, using a stale one would read as a stop and a jump).
  if (t_.linkCounters().failedExchanges() != failuresAtQueue_) {
    // A control write may not have reached the card: without it the next
    // control read-back would look like an index that came. Write it again.
    for (unsigned n = 0; n < count_; ++n)
      if (state_[n].controlQueued) state_[n].writeControl = true;
    return false;
  }
  const double tick = static_cast<double>(tsDivisor_ + 2) / clock_;
  const double span = 65536.0 * tick;  // the 16-bit timestamps wrap after this
  const auto now = t_.now();
  for (unsigned n = 0; n < count_; ++n) {
    auto& s = state_[n];
    s.controlQueued = false;
    const auto raw = static_cast<std::uint16_t>(s.countReg);
    const auto stamp = static_cast<std::uint16_t>(s.countReg >> 16);
    if (s.first) {
      s.lastRaw = raw;
      s.lastTimestamp = stamp;
      s.lastChange = now;
      s.counts = static_cast<std::int16_t>(raw);
      s.first = false;
      continue;
    }
    const auto delta = static_cast<std::int16_t>(static_cast<std::uint16_t>(raw - s.lastRaw));
    const double sinceChange = std::chrono::duration<double>(now - s.lastChange).count();
    if (delta != 0) {
      // The card's timestamps when they cannot have wrapped; the host's
      // clock for slow encoders (fewer than ~30 counts/s).
      const auto dt = static_cast<std::uint16_t>(stamp - s.lastTimestamp);
      if (sinceChange < 0.9 * span && dt > 0)
        s.velocity = delta / (dt * tick);
      else if (sinceChange > 0)
        s.velocity = delta / sinceChange;
      s.lastTimestamp = stamp;
      s.lastChange = now;
    } else if (sinceChange > 0.5) {
      s.velocity = 0;  // stopped
    } else if (sinceChange > 0 && std::abs(s.velocity) * sinceChange > 1.0) {
      s.velocity = (s.velocity > 0 ? 1.0 : -1.0) / sinceChange;  // slowing down: at most a count since
    }
    s.counts += delta;
    s.lastRaw = raw;
    // Index: latch-on-index reads back 0 once the index came.
    if (s.indexArmed && !(s.ccr & kLatchOnIndex)) {
      const auto latched = static_cast<std::uint16_t>(s.ccr >> wire::qcount::ccr::kLatchedShift);
      s.offset = s.counts - static_cast<std::int16_t>(static_cast<std::uint16_t>(raw - latched));
      s.indexArmed = false;
      s.controlOut = kFilter;
      s.writeControl = true;
    }
  }
  return true;
}

}  // namespace lbpkit
