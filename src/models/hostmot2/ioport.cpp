// SPDX-License-Identifier: MIT
#include "hostmot2/ioport.hpp"

namespace lbpkit::model::hm2 {

std::uint32_t IoPort::readRegister(std::uint16_t address, SimTime) {
  const unsigned port = (address & 0xFFU) / 4;
  const unsigned reg = static_cast<unsigned>((address & 0xFF00U) - kData) / kRegisterStride;
  if (port >= ports_ || reg >= 5) return 0;
  if (reg != 0) return regs_[port][reg] & mask();
  std::uint32_t v = 0;
  for (unsigned b = 0; b < width_; ++b) v |= static_cast<std::uint32_t>(pin(port, b)) << b;
  return v;
}

WriteResult IoPort::writeRegister(std::uint16_t address, std::uint32_t value, SimTime) {
  const unsigned port = (address & 0xFFU) / 4;
  const unsigned reg = static_cast<unsigned>((address & 0xFF00U) - kData) / kRegisterStride;
  if (port >= ports_ || reg >= 5) return WriteResult::Unmapped;
  regs_[port][reg] = value & mask();
  if (reg == 1) released_[port] &= ~value;
  return WriteResult::Accepted;
}

void IoPort::setInput(unsigned port, unsigned bit, bool level) {
  if (level)
    inputs_.at(port) |= 1U << bit;
  else
    inputs_.at(port) &= ~(1U << bit);
}

bool IoPort::pin(unsigned port, unsigned bit) const {
  const auto& r = regs_.at(port);
  const bool gpioOutput = ((r[1] >> bit) & 1U) && !((r[2] >> bit) & 1U);
  if (!gpioOutput) return (inputs_[port] >> bit) & 1U;
  const bool level = ((r[0] ^ r[4]) >> bit) & 1U;
  // Open drain drives low only; high is whatever pulls the line up.
  if (((r[3] >> bit) & 1U) && level) return (inputs_[port] >> bit) & 1U;
  return level;
}

IoPort::State IoPort::state() const {
  State s;
  s.ports = ports_;
  s.width = width_;
  for (unsigned p = 0; p < ports_; ++p) {
    const auto& r = regs_[p];
    auto& o = s.port[p];
    for (unsigned b = 0; b < width_; ++b) o.pins |= static_cast<std::uint32_t>(pin(p, b)) << b;
    o.outputLatch = r[0] & mask();
    o.ddr = r[1] & mask();
    o.altSource = r[2] & mask();
    o.openDrain = r[3] & mask();
    o.outputInvert = r[4] & mask();
  }
  return s;
}

void IoPort::reset() {
  // Power-up (HostMot2 regmap, IOPort): outputs latched low, every pin a
  // GPIO input, no alternate source, no open drain, no inversion. The input
  // levels are the world's and stay.
  for (auto& r : regs_) r.fill(0);
  released_.fill(0);
}

void IoPort::releaseOutputs() {
  for (auto& r : regs_) {
    r[0] = 0;
    r[1] = 0;
  }
  released_.fill(mask());
}

}  // namespace lbpkit::model::hm2
