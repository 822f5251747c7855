#include "hostmot2/outm.hpp"

#include <algorithm>

namespace hm2 {

OutM::OutM(std::uint16_t base, unsigned instances, std::uint8_t version)
    : base_(base), instances_(std::min(instances, kMaxInstances)), version_(version) {}

std::uint32_t OutM::read(std::uint16_t address, SimTime) {
  // The data register reads back what was written (outm.c never reads it).
  return decodes(address) ? data_[static_cast<unsigned>(address - base_) / 4] : 0;
}

WriteResult OutM::write(std::uint16_t address, std::uint32_t value, SimTime) {
  if (!decodes(address)) return WriteResult::Unmapped;
  data_[static_cast<unsigned>(address - base_) / 4] = value;
  return WriteResult::Accepted;
}

}  // namespace hm2
