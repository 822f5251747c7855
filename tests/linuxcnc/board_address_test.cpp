// SPDX-License-Identifier: MIT
// A card's address (linuxcnc/board_address.hpp): the strict dotted quad, and
// which addresses a Mesa Ethernet card can have on the network lbpkit
// linuxcnc builds for it.
#include <gtest/gtest.h>

#include <string>

#include "linuxcnc/board_address.hpp"

namespace {

using lbpkit::linuxcnc::boardAddressProblem;
using lbpkit::linuxcnc::formatIpv4;
using lbpkit::linuxcnc::Ipv4;
using lbpkit::linuxcnc::parseIpv4;

TEST(BoardAddress, ParsesOnlyTheStrictDottedQuad) {
  struct Good {
    const char* text;
    std::uint32_t value;
  };
  for (const auto& g : {Good{"10.10.10.10", 0x0A0A0A0A}, Good{"0.0.0.0", 0}, Good{"255.255.255.255", 0xFFFFFFFF},
                        Good{"192.168.1.121", 0xC0A80179}, Good{"1.0.20.255", 0x010014FF}}) {
    const auto a = parseIpv4(g.text);
    ASSERT_TRUE(a) << g.text;
    EXPECT_EQ(a->value, g.value) << g.text;
    EXPECT_EQ(formatIpv4(*a), g.text);
  }
  for (const char* bad :
       {"", ".", "...", "10.1.2", "10.1.2.3.4", "10.1.2.3.", ".10.1.2.3", "10..2.3", "256.1.1.1", "1.2.3.256",
        "1000.1.1.1", "010.1.1.1", "10.01.1.1", "00.1.1.1", "0x0a.1.1.1", "+1.2.3.4", "-1.2.3.4", " 1.2.3.4",
        "1.2.3.4 ", "1.2.3.4\n", "1. 2.3.4", "1.2.3.4/24", "1.2.3.4:27181", "::1", "::ffff:10.1.2.3", "localhost",
        "10.77.1.5;id", "$(touch${IFS}/tmp/x/PWNED1)10.77.1.5", "99999999999999999999.1.1.1", "4294967295"}) {
    EXPECT_FALSE(parseIpv4(bad)) << '"' << bad << '"';
  }
  // A NUL after the address is part of the text, not its end.
  EXPECT_FALSE(parseIpv4(std::string_view("1.2.3.4\0", 8)));
}

TEST(BoardAddress, AcceptsUnicastAddressesAndSaysWhyNotOtherwise) {
  for (const char* good : {"10.10.10.10", "192.168.1.121", "10.77.1.5", "169.254.1.1", "223.255.255.254", "1.0.0.1",
                           "126.255.255.254", "128.0.0.1"})
    EXPECT_EQ(boardAddressProblem(good), std::nullopt) << good << ": " << boardAddressProblem(good).value_or("");
  struct Bad {
    const char* text;
    const char* reason;
  };
  for (const auto& b : {
           Bad{"$(touch${IFS}/tmp/x/PWNED1)10.77.1.5",
               "\"$(touch${IFS}/tmp/x/PWNED1)10.77.1.5\" is not an IPv4 address (four numbers 0-255 joined by dots)"},
           Bad{"10.1.2", "\"10.1.2\" is not an IPv4 address"},
           Bad{"::1", "\"::1\" is not an IPv4 address"},
           Bad{"localhost", "\"localhost\" is not an IPv4 address"},
           Bad{"1.2.3.4 ", "\"1.2.3.4 \" is not an IPv4 address"},
           Bad{"256.1.1.1", "\"256.1.1.1\" is not an IPv4 address"},
           Bad{"010.1.1.1", "\"010.1.1.1\" is not an IPv4 address"},
           Bad{"1.2.3.4\x1b[2J", "\"1.2.3.4\\x1b[2J\" is not an IPv4 address"},
           Bad{"0.0.0.0", "0.0.0.0 is not a unicast address (0.0.0.0/8 means this host)"},
           Bad{"0.1.2.3", "0.1.2.3 is not a unicast address"},
           Bad{"127.0.0.1", "127.0.0.1 is a loopback address"},
           Bad{"127.10.10.10", "127.10.10.10 is a loopback address"},
           Bad{"224.0.0.1", "224.0.0.1 is a multicast address"},
           Bad{"239.255.255.254", "239.255.255.254 is a multicast address"},
           Bad{"240.0.0.1", "240.0.0.1 is a reserved address"},
           Bad{"255.255.255.254", "255.255.255.254 is a reserved address"},
           Bad{"255.255.255.255", "255.255.255.255 is the broadcast address"},
           Bad{"10.1.2.255",
               "10.1.2.255 ends in .255: the broadcast address of its /24, which lbpkit linuxcnc gives the card's "
               "network"},
           Bad{"10.1.2.0", "10.1.2.0 ends in .0: the network address of its /24"},
       }) {
    const auto problem = boardAddressProblem(b.text);
    ASSERT_TRUE(problem) << b.text;
    EXPECT_NE(problem->find(b.reason), std::string::npos) << *problem;
  }
  // A long text is quoted in part.
  const auto long_ = boardAddressProblem(std::string(100000, '1'));
  ASSERT_TRUE(long_);
  EXPECT_LT(long_->size(), 200U) << *long_;
  EXPECT_NE(long_->find("(100000 characters)"), std::string::npos) << *long_;
}

}  // namespace
