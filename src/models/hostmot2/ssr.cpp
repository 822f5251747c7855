#include "hostmot2/ssr.hpp"

#include <algorithm>

namespace hm2 {

Ssr::Ssr(std::uint16_t base, unsigned instances, std::uint32_t clockLow, std::uint8_t version)
    : base_(base), instances_(std::min(instances, kMaxInstances)), clock_(clockLow), version_(version) {}

bool Ssr::decodes(std::uint16_t a) const {
  if (a < base_ || a >= base_ + kRegisters * kRegisterStride) return false;
  return (a & 0xFFU) < instances_ * 4;
}

void Ssr::reset() {
  data_.fill(0);
  rate_.fill(0);
}

std::uint32_t Ssr::read(std::uint16_t address, SimTime) {
  if (!decodes(address)) return 0;
  const unsigned n = (address & 0xFFU) / 4;
  // Both registers read back what was written (ssr.c never reads them).
  return static_cast<unsigned>(address - base_) / kRegisterStride == kData ? data_[n] : rate_[n];
}

WriteResult Ssr::write(std::uint16_t address, std::uint32_t value, SimTime) {
  if (!decodes(address)) return WriteResult::Unmapped;
  const unsigned n = (address & 0xFFU) / 4;
  if (static_cast<unsigned>(address - base_) / kRegisterStride == kData)
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

}  // namespace hm2
