// SPDX-License-Identifier: MIT
#include "lbpkit/wire/serial_speed.hpp"

#include <termios.h>

#include <array>
#include <utility>

namespace lbpkit::wire {

namespace {
constexpr std::array<std::pair<unsigned, speed_t>, 15> kSpeeds = {{
    {9600, B9600},
    {19200, B19200},
    {38400, B38400},
    {57600, B57600},
    {115200, B115200},
    {230400, B230400},
    {460800, B460800},
    {500000, B500000},
    {921600, B921600},
    {1000000, B1000000},
    {1500000, B1500000},
    {2000000, B2000000},
    {2500000, B2500000},
    {3000000, B3000000},
    {4000000, B4000000},
}};
}  // namespace

std::optional<unsigned> termiosSpeed(unsigned baud) {
  for (const auto& [rate, speed] : kSpeeds)
    if (rate == baud) return static_cast<unsigned>(speed);
  return std::nullopt;
}

}  // namespace lbpkit::wire
