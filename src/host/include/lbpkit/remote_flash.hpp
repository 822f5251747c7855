// SPDX-License-Identifier: MIT
// Updating a smart-serial remote's firmware over LBP, as Mesa's UFLBP and
// LinuxCNC's setsserial do it (manual: RPD, WPD, AND UFLBP; the accesses in
// docs/protocol-facts.md#the-program-flash), with what they lack: each
// commit's status checked, and the flash read back and compared with the
// file. The remote must be in setup mode (W4/W12) on a channel started in
// setup mode at 115200 baud.
#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
#include <span>

#include "lbpkit/discovery.hpp"

namespace lbpkit {

struct FlashGeometry {
  std::size_t eraseBytes = 0;  // 1 << the byte at 0x8004
  std::size_t writeBytes = 0;  // 1 << the byte at 0x8005
  // The whole flash, boot block included: LBP does not report it; a 7I77
  // processor's (wire::i7i77::kProgramFlashBytes, lbpkit's choice).
  std::size_t flashBytes = 0;
};

struct FlashProgress {
  enum class Step { Erased, Written, Skipped, Verified };
  Step step;
  std::size_t block;   // erase block number (block 0, the boot block, is never written)
  std::size_t blocks;  // blocks in the file
};

// NV access to flash and the geometry the remote reports. Throws
// lbpkit::Error when the remote refuses flash access (not in setup mode, or
// no flash) or reports a geometry LBP's 8-byte writes cannot fill.
FlashGeometry flashGeometry(RemoteAccess& remote);

// Writes `image` (a whole-flash file: block 0 ignored, all-zero blocks
// skipped, as setsserial does) and, with `verify`, reads every block
// written back and compares it. Throws lbpkit::Error naming the block and
// what went wrong (a refused commit, a lost cookie, a byte that differs),
// or, before anything is erased, that the image is larger than the flash.
// Returns how many blocks were written.
std::size_t flashRemote(RemoteAccess& remote, std::span<const std::uint8_t> image, bool verify,
                        const std::function<void(const FlashProgress&)>& progress = {});

}  // namespace lbpkit
