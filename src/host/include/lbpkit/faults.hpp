// SPDX-License-Identifier: MIT
// Names for SSLBP's CS bits and a remote's fault byte (manual: CS REGISTER
// AFTER START, CS REGISTER AFTER DOIT).
#pragma once

#include <cstdint>
#include <string>

namespace lbpkit {

// "CRCError TimeoutError" for CS byte 0, status byte 1 bits, and byte 3.
std::string describeLocalFaults(std::uint8_t byte0);
std::string describeStatus(std::uint8_t byte1);
std::string describeRemoteFaults(std::uint8_t faultByte);
// The whole CS register: "ok", or every named bit.
std::string describeCs(std::uint32_t cs);
// LBP status (local read 0xC1).
std::string describeLbpStatus(std::uint8_t status);

}  // namespace lbpkit
