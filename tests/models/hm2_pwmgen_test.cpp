// SPDX-License-Identifier: MIT
// HostMot2 PWMGen as LinuxCNC's pwmgen.c drives it: registers, duty cycle
// from the value, frequency from the rate (docs/hostmot2-modules.md#pwmgen).
#include <gtest/gtest.h>

#include <cstdint>

#include "hostmot2/pwmgen.hpp"
#include "support/hm2_module_expect.hpp"

// The layers' namespaces this file names (docs/architecture.md).
namespace hm2 = lbpkit::model::hm2;

namespace {

using hm2::PwmGen;
using hm2::SimTime;

constexpr std::uint32_t kClockHigh = 200'000'000;
constexpr std::uint16_t kBase = PwmGen::kKind.base;

std::uint16_t reg(unsigned r, unsigned instance = 0) {
  return static_cast<std::uint16_t>(kBase + r * hm2::kRegisterStride + instance * 4);
}

TEST(PwmGen, DescriptorIsWhatLinuxCncAccepts) {
  PwmGen p(kBase, 4, kClockHigh);
  // ClockHigh: pwmrefh runs on hclk.
  testing_hm2::expectDescriptor(p.descriptor(), {6, 0, hm2::kClockHigh, 4, 0x4000, 5, 0, 0x03});
}

TEST(PwmGen, RegistersRoundTripWithTheirWidths) {
  PwmGen p(kBase, 2, kClockHigh);
  const SimTime t{};
  EXPECT_EQ(p.write(reg(PwmGen::kValue, 1), 0xFFFFFFFFU, t), hm2::WriteResult::Accepted);
  EXPECT_EQ(p.read(reg(PwmGen::kValue, 1), t), 0x8FFF0000U);  // dir + 12 value bits
  EXPECT_EQ(p.read(reg(PwmGen::kValue, 0), t), 0U);
  p.write(reg(PwmGen::kMode, 0), 0xFFU, t);
  EXPECT_EQ(p.read(reg(PwmGen::kMode, 0), t), 0x3FU);
  p.write(0x4200, 0x12345U, t);
  EXPECT_EQ(p.read(0x4200, t), 0x2345U);  // 16-bit DDS
  p.write(0x4300, 0xFFFFU, t);
  EXPECT_EQ(p.read(0x4300, t), 0xFFFFU);
  p.write(0x4400, 0xFFU, t);
  EXPECT_EQ(p.read(0x4400, t), 0x3U);  // one enable bit per instance
  EXPECT_FALSE(p.decodes(0x4404));
  EXPECT_FALSE(p.decodes(reg(PwmGen::kValue, 2)));
  EXPECT_EQ(p.write(reg(PwmGen::kMode, 2), 1, t), hm2::WriteResult::Unmapped);
  p.reset();
  EXPECT_EQ(p.read(reg(PwmGen::kValue, 1), t), 0U);
  EXPECT_FALSE(p.output(0).enabled);
}

TEST(PwmGen, DutyCycleFromValueAsLinuxCncScalesIt) {
  PwmGen p(kBase, 1, kClockHigh);
  const SimTime t{};
  // pwmgen.c: value = |duty| * (2^bits - 1) << 16, bit 31 for negative;
  // mode: width code | output type << 3 | double buffered << 5.
  for (unsigned code = 0; code < 4; ++code) {
    const unsigned bits = 9 + code;
    p.write(reg(PwmGen::kMode), code | (1U << 5), t);
    const auto value = static_cast<std::uint32_t>(0.25 * ((1U << bits) - 1));
    p.write(reg(PwmGen::kValue), value << 16 | PwmGen::kDirection, t);
    const auto o = p.output(0);
    EXPECT_DOUBLE_EQ(o.duty, static_cast<double>(value) / (1U << bits)) << bits;
    EXPECT_NEAR(o.duty, 0.25, 0.002);
    EXPECT_TRUE(o.direction);
    EXPECT_EQ(o.mode, PwmGen::OutputMode::PwmDir);
  }
  // Full scale at 9 bits; a larger value than the width holds it high.
  p.write(reg(PwmGen::kMode), 0, t);
  p.write(reg(PwmGen::kValue), 0xFFFU << 16, t);
  EXPECT_DOUBLE_EQ(p.duty(0), 1.0);
  // PDM: density value / 4096 whatever the width.
  p.write(reg(PwmGen::kMode), (3U << 3) | 1U, t);
  p.write(reg(PwmGen::kValue), 1024U << 16, t);
  EXPECT_DOUBLE_EQ(p.duty(0), 0.25);
  EXPECT_EQ(p.output(0).mode, PwmGen::OutputMode::PdmDir);
  // The enable bit drives only /enable.
  p.write(0x4400, 1, t);
  EXPECT_TRUE(p.output(0).enabled);
  EXPECT_DOUBLE_EQ(p.duty(0), 0.25);
}

TEST(PwmGen, FrequencyFromTheMasterRate) {
  PwmGen p(kBase, 1, kClockHigh);
  const SimTime t{};
  // pwmgen.c for 20 kHz at 12 bits: DDS = 20000 * 65536 * 4096 / ClockHigh.
  const auto dds = static_cast<std::uint32_t>(20000.0 * 65536.0 * 4096.0 / kClockHigh);
  p.write(0x4200, dds, t);
  p.write(reg(PwmGen::kMode), 3, t);
  EXPECT_NEAR(p.frequency(0), 20000.0, 20000.0 / dds + 1e-9);
  p.write(reg(PwmGen::kMode), 3 | PwmGen::kSymmetrical, t);
  EXPECT_NEAR(p.frequency(0), 10000.0, 10000.0 / dds + 1e-9);
  // PDM pulse clock: ClockHigh * DDS / 65536.
  p.write(0x4300, 6554, t);
  p.write(reg(PwmGen::kMode), 3U << 3, t);
  EXPECT_DOUBLE_EQ(p.frequency(0), kClockHigh * (6554 / 65536.0));
}

}  // namespace
