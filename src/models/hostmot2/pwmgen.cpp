// SPDX-License-Identifier: MIT
#include "hostmot2/pwmgen.hpp"

#include <algorithm>

namespace lbpkit::model::hm2 {

namespace {
constexpr std::uint32_t kValueMask = 0xFFFU << 16;  // PWMRefWidth 13: 12 value bits at 27..16
constexpr std::uint32_t kModeMask = 0x3FU;
}  // namespace

PwmGen::PwmGen(std::uint16_t base, unsigned instances, std::uint32_t clockHigh, std::uint8_t version)
    : Module(kKind, base, std::min(instances, kMaxInstances), version), clock_(clockHigh) {}

void PwmGen::reset() {
  // Power-up: every register 0 (value 0, 9-bit PWM/dir, rates 0: the PWM
  // counter stands), every /enable pin high.
  pwmRate_ = pdmRate_ = enable_ = 0;
  value_.fill(0);
  mode_.fill(0);
}

std::uint32_t PwmGen::readRegister(std::uint16_t address, SimTime) {
  const unsigned n = (address & 0xFFU) / 4;
  // Only the enable register reads back in the firmware (boutreg); lbpkit
  // reads back what was written everywhere, which no driver relies on.
  switch (block(address)) {
    case kValue: return value_[n];
    case kMode: return mode_[n];
    case kPwmRate: return pwmRate_;
    case kPdmRate: return pdmRate_;
    case kEnable: return enable_;
    default: return 0;
  }
}

WriteResult PwmGen::writeRegister(std::uint16_t address, std::uint32_t value, SimTime) {
  const unsigned n = (address & 0xFFU) / 4;
  // A double-buffered value takes effect at the start of the next PWM cycle
  // (at most one period later); the model applies it at once.
  switch (block(address)) {
    case kValue: value_[n] = value & (kValueMask | kDirection); break;
    case kMode: mode_[n] = value & kModeMask; break;
    case kPwmRate: pwmRate_ = value & 0xFFFFU; break;
    case kPdmRate: pdmRate_ = value & 0xFFFFU; break;
    case kEnable: enable_ = instances_ >= 32 ? value : value & ((1U << instances_) - 1); break;
    default: return WriteResult::Unmapped;
  }
  return WriteResult::Accepted;
}

PwmGen::Output PwmGen::output(unsigned n) const {
  const std::uint32_t v = value_.at(n);
  const std::uint32_t m = mode_.at(n);
  Output o;
  o.mode = static_cast<OutputMode>((m >> 3) & 3U);
  o.direction = (v & kDirection) != 0;
  o.enabled = ((enable_ >> n) & 1U) != 0;
  const std::uint32_t level = (v & kValueMask) >> 16;
  if (o.mode == OutputMode::PdmDir) {
    // pwmpdmgenh.vhd: the carry of a 12-bit accumulator adding the value.
    o.duty = level / 4096.0;
  } else {
    // High while the (width-bit) counter is below the value.
    const std::uint32_t full = 1U << (9 + (m & 3U));
    o.duty = static_cast<double>(std::min(level, full)) / full;
  }
  return o;
}

double PwmGen::frequency(unsigned n) const {
  const std::uint32_t m = mode_.at(n);
  if (((m >> 3) & 3U) == static_cast<unsigned>(OutputMode::PdmDir)) return clock_ * (pdmRate_ / 65536.0);
  const double counter = clock_ * (pwmRate_ / 65536.0);
  const double period = static_cast<double>(1U << (9 + (m & 3U))) * ((m & kSymmetrical) != 0 ? 2.0 : 1.0);
  return counter / period;
}

PwmGen::State PwmGen::state() const {
  State s;
  s.instances = instances_;
  s.pwmRate = pwmRate_;
  s.pdmRate = pdmRate_;
  s.enable = enable_;
  s.value = value_;
  s.mode = mode_;
  return s;
}

}  // namespace lbpkit::model::hm2
