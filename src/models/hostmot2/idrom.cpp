// SPDX-License-Identifier: MIT
#include "hostmot2/idrom.hpp"

#include <algorithm>

namespace lbpkit::model::hm2 {

namespace {
std::uint32_t fourChars(std::string_view s, std::size_t at) {
  std::uint32_t v = 0;
  for (std::size_t i = 0; i < 4; ++i) {
    const auto c = at + i < s.size() ? static_cast<std::uint8_t>(s[at + i]) : std::uint8_t{' '};
    v |= static_cast<std::uint32_t>(c) << (8 * i);
  }
  return v;
}
using namespace pincode;
}  // namespace

std::array<std::uint32_t, idrom::kWords> buildIdrom(const BoardIdentity& board,
                                                    std::span<const ModuleDescriptor> modules,
                                                    std::span<const PinDescriptor> pins) {
  std::array<std::uint32_t, idrom::kWords> w{};
  auto at = [&](unsigned byteOffset) -> std::uint32_t& { return w[byteOffset / 4]; };
  at(0) = wire::hm2::idrom::kIdromType;
  at(4) = wire::hm2::idrom::kOffsetToModules;
  at(8) = wire::hm2::idrom::kOffsetToPins;
  at(wire::hm2::idrom::kBoardNameLow) = fourChars(board.boardName, 0);
  at(wire::hm2::idrom::kBoardNameHigh) = fourChars(board.boardName, 4);
  at(wire::hm2::idrom::kFpgaSize) = board.fpgaSize;
  at(wire::hm2::idrom::kFpgaPins) = board.fpgaPins;
  at(wire::hm2::idrom::kIoPorts) = board.ioPorts;
  at(wire::hm2::idrom::kIoWidth) = board.ioPorts * board.portWidth;
  at(wire::hm2::idrom::kPortWidth) = board.portWidth;
  at(wire::hm2::idrom::kClockLow) = board.clockLow;
  at(wire::hm2::idrom::kClockHigh) = board.clockHigh;
  at(wire::hm2::idrom::kInstanceStride0) = kInstanceStride0;
  at(wire::hm2::idrom::kInstanceStride1) = kInstanceStride1;
  at(wire::hm2::idrom::kRegisterStride0) = kRegisterStride;
  at(wire::hm2::idrom::kRegisterStride1) = kRegisterStride;
  const std::size_t nm = std::min<std::size_t>(modules.size(), idrom::kMaxModules - 1);  // a zero record ends the list
  for (std::size_t i = 0; i < nm; ++i) {
    const auto& m = modules[i];
    const unsigned base = wire::hm2::idrom::kOffsetToModules + static_cast<unsigned>(i) * 12;
    at(base) = static_cast<std::uint32_t>(m.gtag) | (static_cast<std::uint32_t>(m.version) << 8) |
               (static_cast<std::uint32_t>(m.clockTag) << 16) | (static_cast<std::uint32_t>(m.instances) << 24);
    at(base + 4) = static_cast<std::uint32_t>(m.baseAddress) | (static_cast<std::uint32_t>(m.registers) << 16) |
                   (static_cast<std::uint32_t>(m.strides) << 24);
    at(base + 8) = m.multipleRegisters;
  }
  const std::size_t np = std::min<std::size_t>(pins.size(), idrom::kMaxPins);
  for (std::size_t i = 0; i < np; ++i)
    at(wire::hm2::idrom::kOffsetToPins + static_cast<unsigned>(i) * 4) = pins[i].word();
  return w;
}

std::array<PinDescriptor, 17> sevenI77Pins(unsigned firstChannel, unsigned firstUnit, unsigned selectUnit) {
  auto ss = [&](std::uint8_t kind, unsigned channel) {
    return PinDescriptor{static_cast<std::uint8_t>(kind + firstChannel + channel + 1), tag::kSSerial, 0};
  };
  auto qc = [&](std::uint8_t pin, unsigned pair) {
    return PinDescriptor{pin, tag::kMuxedQCount, static_cast<std::uint8_t>(firstUnit + pair)};
  };
  return {ss(kSsTxEn, 2), ss(kSsTx, 2),  ss(kSsRx, 2),  ss(kSsTx, 1), ss(kSsRx, 1),
          ss(kSsTx, 0),   ss(kSsRx, 0),  PinDescriptor{kSel0, tag::kMuxedQCountSel, static_cast<std::uint8_t>(selectUnit)},
          qc(kQcA, 0),    qc(kQcB, 0),   qc(kQcIdx, 0), qc(kQcA, 1),  qc(kQcB, 1),
          qc(kQcIdx, 1),  qc(kQcA, 2),   qc(kQcB, 2),   qc(kQcIdx, 2)};
}

std::array<PinDescriptor, 17> sevenI76Pins(unsigned firstStepGen, unsigned channel, unsigned counterUnit) {
  auto sg = [&](std::uint8_t pin, unsigned n) {
    return PinDescriptor{pin, tag::kStepGen, static_cast<std::uint8_t>(firstStepGen + n)};
  };
  auto ss = [&](std::uint8_t kind, unsigned ch) {
    return PinDescriptor{static_cast<std::uint8_t>(kind + ch + 1), tag::kSSerial, 0};
  };
  auto qc = [&](std::uint8_t pin) { return PinDescriptor{pin, tag::kMuxedQCount, static_cast<std::uint8_t>(counterUnit)}; };
  return {sg(kDir, 0),       sg(kStep, 0),          sg(kDir, 1),           sg(kStep, 1),      sg(kDir, 2),
          sg(kStep, 2),      sg(kDir, 3),           sg(kStep, 3),          sg(kDir, 4),       sg(kStep, 4),
          ss(kSsTx, channel), ss(kSsRx, channel),   ss(kSsTx, channel + 1), ss(kSsRx, channel + 1), qc(kQcIdx),
          qc(kQcB),          qc(kQcA)};
}

}  // namespace lbpkit::model::hm2
