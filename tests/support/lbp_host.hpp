// SPDX-License-Identifier: MIT
// Test helper: the host side of an LBP exchange with a remote device model.
#pragma once

#include <gtest/gtest.h>

#include <cstdint>
#include <optional>
#include <vector>

#include "lbp/protocol.hpp"
#include "remote/remote_device.hpp"

namespace testing_lbp {

using Bytes = std::vector<std::uint8_t>;

inline Bytes withCrc(Bytes b) {
  b.push_back(lbpkit::model::lbp::crc8(b));
  return b;
}

// Sends `command` (CRC appended) one character at a time at the device's
// baud rate, starting at `now`, and returns what came back.
class Host {
 public:
  explicit Host(lbpkit::model::remote::RemoteDevice& d,
                lbpkit::model::lbp::SimTime start = lbpkit::model::lbp::SimTime{0})
      : dev(d), now(start) {}

  Bytes raw(const Bytes& bytes) {
    Bytes reply;
    for (auto b : bytes) {
      now += lbpkit::model::lbp::characterTime(dev.baud());
      auto r = dev.receive(b, now);
      reply.insert(reply.end(), r.begin(), r.end());
    }
    now += lbpkit::model::lbp::characterTime(dev.baud()) * 2;
    return reply;
  }
  Bytes send(const Bytes& command) { return raw(withCrc(command)); }

  // Data bytes of a reply after checking its CRC; nullopt if none came back.
  std::optional<Bytes> transact(const Bytes& command, std::size_t dataBytes) {
    Bytes r = send(command);
    if (r.size() != dataBytes + 1) return std::nullopt;
    EXPECT_EQ(lbpkit::model::lbp::crc8(r), 0) << "reply CRC";
    r.pop_back();
    return r;
  }
  std::uint64_t read(std::uint16_t address, std::uint8_t size) {
    auto r = transact({lbpkit::model::lbp::readHeader(size, true), static_cast<std::uint8_t>(address & 0xFF),
                       static_cast<std::uint8_t>(address >> 8)},
                      size);
    EXPECT_TRUE(r.has_value()) << "read at " << address;
    std::uint64_t v = 0;
    if (r)
      for (std::size_t i = 0; i < r->size(); ++i) v |= static_cast<std::uint64_t>((*r)[i]) << (8 * i);
    return v;
  }
  bool write(std::uint16_t address, std::uint8_t size, std::uint64_t value) {
    Bytes c{lbpkit::model::lbp::writeHeader(size, true), static_cast<std::uint8_t>(address & 0xFF),
            static_cast<std::uint8_t>(address >> 8)};
    for (unsigned i = 0; i < size; ++i) c.push_back(static_cast<std::uint8_t>(value >> (8 * i)));
    return send(c) == Bytes{0x00};
  }
  std::uint8_t local(std::uint8_t command) {
    auto r = transact({command}, 1);
    return r ? (*r)[0] : 0xEE;
  }
  bool setLocal(std::uint8_t command, std::uint8_t value) { return send({command, value}) == Bytes{0x00}; }
  Bytes processData(const Bytes& out) {
    Bytes c{lbpkit::model::lbp::special_rpc::kProcessData};
    c.insert(c.end(), out.begin(), out.end());
    auto r = transact(c, dev.discovery().rxSize);
    EXPECT_TRUE(r.has_value());
    return r.value_or(Bytes{});
  }
  void wait(lbpkit::model::lbp::SimTime t) {
    now += t;
    dev.advance(now);
  }

  lbpkit::model::remote::RemoteDevice& dev;
  lbpkit::model::lbp::SimTime now;
};

}  // namespace testing_lbp
