// SPDX-License-Identifier: MIT
#include "hostmot2/outm.hpp"

#include <algorithm>

namespace lbpkit::model::hm2 {

OutM::OutM(std::uint16_t base, unsigned instances, std::uint8_t version)
    : Module(kKind, base, std::min(instances, kMaxInstances), version) {}

std::uint32_t OutM::readRegister(std::uint16_t address, SimTime) {
  // The data register reads back what was written (outm.c never reads it).
  return data_[instanceOf(address)];
}

WriteResult OutM::writeRegister(std::uint16_t address, std::uint32_t value, SimTime) {
  data_[instanceOf(address)] = value;
  return WriteResult::Accepted;
}

}  // namespace lbpkit::model::hm2
