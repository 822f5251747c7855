// SPDX-License-Identifier: MIT
// hostmot2's HAL names (linuxcnc/hal_name.hpp), read and made in one place:
// a board, a module's pin, a smart-serial remote's pin, and what is none of
// them.
#include <gtest/gtest.h>

#include <string>

#include "linuxcnc/hal_name.hpp"

namespace {

namespace hal_name = lbpkit::linuxcnc::hal_name;

TEST(HalName, ABoardIsItsNameAndNumber) {
  const auto n = hal_name::parse("hm2_7i96s.1.encoder.00.position");
  ASSERT_TRUE(n);
  EXPECT_EQ(n->board, "7i96s");
  EXPECT_EQ(n->index, 1U);
  EXPECT_EQ(n->prefix(), "hm2_7i96s.1");
  EXPECT_EQ(n->parts, (std::vector<std::string>{"encoder", "00", "position"}));
  EXPECT_EQ(hal_name::parse("hm2_5i25.0")->prefix(), "hm2_5i25.0");
  for (const char* none : {"", "hm2_", "hm2_.0", "hm2_7i92", "hm2_7i92.x.encoder.00.position", "pid.x.output",
                           "hm2_7i92.1234", "HM2_7I92.0"})
    EXPECT_FALSE(hal_name::parse(none)) << none;
}

TEST(HalName, AModulesPinHasItsInstanceAndLeaf) {
  const auto m = hal_name::parseModule("hm2_7i92.0.stepgen.03.position-cmd");
  ASSERT_TRUE(m);
  EXPECT_EQ(m->board.prefix(), "hm2_7i92.0");
  EXPECT_EQ(m->module, "stepgen");
  EXPECT_EQ(m->instance, 3U);
  EXPECT_EQ(m->leaf, "position-cmd");
  EXPECT_EQ(hal_name::parseModule("hm2_7i96s.0.gpio.012.in_not")->instance, 12U);
  for (const char* none : {"hm2_7i92.0.stepgen.03", "hm2_7i92.0.stepgen.x3.position-cmd",
                           "hm2_7i92.0.7i77.0.1.analogout0", "hm2_7i92.0.watchdog.has_bit"})
    EXPECT_FALSE(hal_name::parseModule(none)) << none;
}

TEST(HalName, ARemotesPinHasItsPortChannelAndLeaf) {
  const auto r = hal_name::parseRemote("hm2_7i92.0.7i77.0.1.analogout5");
  ASSERT_TRUE(r);
  EXPECT_EQ(r->remote, "7i77");
  EXPECT_EQ(r->port, 0U);
  EXPECT_EQ(r->channel, 1U);
  EXPECT_EQ(r->leaf, "analogout5");
  EXPECT_EQ(hal_name::parseRemote("hm2_7i92.0.7i76.0.3.input-07-not")->remote, "7i76");
  for (const char* none : {"hm2_7i92.0.7i78.0.1.analogout5", "hm2_7i92.0.7i77.0.analogout5",
                           "hm2_7i92.0.encoder.00.position", "hm2_7i92.0.7i77.a.1.analogout5"})
    EXPECT_FALSE(hal_name::parseRemote(none)) << none;
}

TEST(HalName, NamesAreMadeAsHostmot2WritesThem) {
  EXPECT_EQ(hal_name::board("7i92", 0), "hm2_7i92.0");
  EXPECT_EQ(hal_name::module("hm2_7i92.0", "encoder", 5), "hm2_7i92.0.encoder.05");
  EXPECT_EQ(hal_name::module("hm2_7i92.0", "gpio", 5), "hm2_7i92.0.gpio.005");
  EXPECT_EQ(hal_name::remote("hm2_7i92.0", "7i77", 0, 4), "hm2_7i92.0.7i77.0.4");
  // What is made reads back.
  const auto m = hal_name::parseModule(hal_name::module(hal_name::board("7i80hd", 2), "pwmgen", 1) + ".value");
  ASSERT_TRUE(m);
  EXPECT_EQ(m->board.board, "7i80hd");
  EXPECT_EQ(m->board.index, 2U);
  EXPECT_EQ(m->instance, 1U);
}

TEST(HalName, EthernetBoardsAreHm2EthsAndThePciCardsAreNot) {
  for (const char* eth : {"7i92", "7i96s", "7i96", "7i80hd", "7i80db", "7i76e", "7i93", "7i94", "7i95", "7i97"})
    EXPECT_TRUE(hal_name::isEthernetBoard(eth)) << eth;
  for (const char* pci : {"5i25", "6i25", "5i24", "7i90"}) EXPECT_FALSE(hal_name::isEthernetBoard(pci)) << pci;
}

}  // namespace
