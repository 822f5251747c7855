// SPDX-License-Identifier: MIT
#include "hostmot2/ssr.hpp"

#include <algorithm>

namespace lbpkit::model::hm2 {

Ssr::Ssr(std::uint16_t base, unsigned instances, std::uint32_t clockLow, std::uint8_t version)
    : Module(kKind, base, std::min(instances, kMaxInstances), version), clock_(clockLow) {}

void Ssr::reset() {
  data_.fill(0);
  rate_.fill(0);
}

std::uint32_t Ssr::readRegister(std::uint16_t address, SimTime) {
  const unsigned n = (address & 0xFFU) / 4;
  // Both registers read back what was written (ssr.c never reads them).
  return block(address) == kData ? data_[n] : rate_[n];
}

WriteResult Ssr::writeRegister(std::uint16_t address, std::uint32_t value, SimTime) {
  const unsigned n = (address & 0xFFU) / 4;
  if (block(address) == kData)
    data_[n] = value;
  else
    rate_[n] = value & (kDivisorMask | kEnable);
  return WriteResult::Accepted;
}

bool Ssr::closed(unsigned instance, unsigned n) const {
  return driving(instance) && ((data_.at(instance) >> n) & 1U) != 0;
}

double Ssr::driveFrequency(unsigned instance) const {
  if (!driving(instance)) return 0.0;
  return static_cast<double>(clock_) / ((rate_[instance] & kDivisorMask) + 2) / 2;
}

}  // namespace lbpkit::model::hm2
