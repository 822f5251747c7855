// SPDX-License-Identifier: MIT
// Shared by the HostMot2 module tests: a module's IDROM record, field by field.
#pragma once

#include <gtest/gtest.h>

#include "hostmot2/module.hpp"

namespace testing_hm2 {

inline void expectDescriptor(const lbpkit::model::hm2::ModuleDescriptor& got,
                             const lbpkit::model::hm2::ModuleDescriptor& want) {
  EXPECT_EQ(got.gtag, want.gtag);
  EXPECT_EQ(got.version, want.version);
  EXPECT_EQ(got.clockTag, want.clockTag);
  EXPECT_EQ(got.instances, want.instances);
  EXPECT_EQ(got.baseAddress, want.baseAddress);
  EXPECT_EQ(got.registers, want.registers);
  EXPECT_EQ(got.strides, want.strides);
  EXPECT_EQ(got.multipleRegisters, want.multipleRegisters);
}

}  // namespace testing_hm2
