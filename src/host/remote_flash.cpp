// SPDX-License-Identifier: MIT
#include "lbpkit/remote_flash.hpp"

#include <string>
#include <vector>

#include "lbpkit/error.hpp"
#include "lbpkit/wire/lbp.hpp"
#include "lbpkit/wire/seven_i77.hpp"

namespace lbpkit {

namespace lbp = wire::lbp;

namespace {

// NV access set to flash, or back to none, for the span of a scope.
class FlashAccess {
 public:
  explicit FlashAccess(RemoteAccess& r) : r_(r) { r_.localWrite(lbp::local_write::kNonVolatile, lbp::nonvolatile::kFlash); }
  ~FlashAccess() {
    try {
      r_.localWrite(lbp::local_write::kNonVolatile, lbp::nonvolatile::kNone);
    } catch (...) {  // the remote is gone: what failed is already being reported
    }
  }
  FlashAccess(const FlashAccess&) = delete;
  FlashAccess& operator=(const FlashAccess&) = delete;

 private:
  RemoteAccess& r_;
};

// The LBP status after a commit: an Invalid write is the remote refusing
// it; the cookie says the remote is still in step (setsserial's check).
void checkCommit(RemoteAccess& r, const char* what, std::size_t block) {
  const std::uint8_t status = r.localRead(lbp::local_read::kStatus);
  if (status & lbp::status::kInvalidWrite)
    throw Error(r.where() + ": the remote refused to " + what + " block " + std::to_string(block) +
                " (LBP invalid write)");
  if (r.localRead(lbp::local_read::kCookie) != lbp::kCookie)
    throw Error(r.where() + ": lost step with the remote after it was to " + what + " block " + std::to_string(block));
}

std::string hex(std::size_t v) {
  static constexpr char kDigits[] = "0123456789abcdef";
  std::string s;
  do {
    s.insert(s.begin(), kDigits[v & 0xF]);
    v >>= 4;
  } while (v != 0);
  return "0x" + s;
}

std::uint64_t le64(std::span<const std::uint8_t> at) {
  std::uint64_t v = 0;
  for (std::size_t k = 0; k < 8; ++k) v |= std::uint64_t{at[k]} << (8 * k);
  return v;
}

}  // namespace

FlashGeometry flashGeometry(RemoteAccess& remote) {
  remote.localWrite(lbp::local_write::kStatus, 0);
  FlashAccess access(remote);
  if (remote.localRead(lbp::local_read::kNonVolatile) != lbp::nonvolatile::kFlash)
    throw Error(remote.where() + ": the remote refused flash access: a 7I77 takes firmware in setup mode only (W12 for "
                                 "the field I/O processor, W4 for the analog one)");
  const unsigned write = static_cast<unsigned>(remote.read(lbp::flash::kWriteSize, 1));
  const unsigned erase = static_cast<unsigned>(remote.read(lbp::flash::kEraseSize, 1));
  if (write < 3 || write > 12 || erase < write || erase > 20)
    throw Error(remote.where() + ": the remote reports a flash of " + std::to_string(1U << std::min(erase, 20U)) +
                "-byte blocks in " + std::to_string(1U << std::min(write, 20U)) +
                "-byte pages, which 8-byte LBP writes cannot program");
  return {std::size_t{1} << erase, std::size_t{1} << write, wire::i7i77::kProgramFlashBytes};
}

std::size_t flashRemote(RemoteAccess& remote, std::span<const std::uint8_t> image, bool verify,
                        const std::function<void(const FlashProgress&)>& progress) {
  const FlashGeometry g = flashGeometry(remote);
  // An image past the flash's end would be cut at the first block the
  // remote refuses, after the blocks before it were erased: refused whole.
  if (image.size() > g.flashBytes)
    throw Error(remote.where() + ": an image of " + std::to_string(image.size()) + " bytes is larger than the " +
                std::to_string(g.flashBytes) + "-byte (" + std::to_string(g.flashBytes / 1024) +
                " KiB) program flash: nothing was erased");
  const std::size_t blocks = (image.size() + g.eraseBytes - 1) / g.eraseBytes;
  auto tell = [&](FlashProgress::Step step, std::size_t block) {
    if (progress) progress({step, block, blocks});
  };
  // The file's bytes, erased (0xFF) past its end, as a page is written.
  auto byteAt = [&](std::size_t at) -> std::uint8_t { return at < image.size() ? image[at] : 0xFF; };
  std::vector<std::size_t> written;
  for (std::size_t block = 1; block < blocks; ++block) {
    const std::size_t start = block * g.eraseBytes;
    bool zero = true;
    for (std::size_t t = start; t < start + g.eraseBytes && zero; ++t) zero = byteAt(t) == 0;
    if (zero) {
      tell(FlashProgress::Step::Skipped, block);
      continue;
    }
    FlashAccess access(remote);
    remote.write(lbp::flash::kOffset, 4, start);
    remote.write(lbp::flash::kCommit, 1, lbp::flash::kErase);
    checkCommit(remote, "erase", block);
    tell(FlashProgress::Step::Erased, block);
    for (std::size_t page = start; page < start + g.eraseBytes; page += g.writeBytes) {
      std::uint8_t bytes[8];
      remote.write(lbp::flash::kOffset, 4, page);
      for (std::size_t j = 0; j < g.writeBytes; j += 8) {
        for (std::size_t k = 0; k < 8; ++k) bytes[k] = byteAt(page + j + k);
        remote.write(static_cast<std::uint16_t>(j), 8, le64(bytes));
      }
      remote.write(lbp::flash::kCommit, 1, lbp::flash::kWrite);
      checkCommit(remote, "write", block);
    }
    tell(FlashProgress::Step::Written, block);
    written.push_back(block);
  }
  if (verify) {
    // Read back through the page buffer's addresses at each page's offset.
    FlashAccess access(remote);
    for (const std::size_t block : written) {
      for (std::size_t page = block * g.eraseBytes; page < (block + 1) * g.eraseBytes; page += g.writeBytes) {
        remote.write(lbp::flash::kOffset, 4, page);
        for (std::size_t j = 0; j < g.writeBytes; j += 8) {
          const std::uint64_t got = remote.read(static_cast<std::uint16_t>(j), 8);
          for (std::size_t k = 0; k < 8; ++k) {
            const auto byte = static_cast<std::uint8_t>(got >> (8 * k));
            if (byte != byteAt(page + j + k))
              throw Error(remote.where() + ": block " + std::to_string(block) + " does not read back as written: at " +
                          hex(page + j + k) + " the flash has " + hex(byte) + ", the file " + hex(byteAt(page + j + k)));
          }
        }
      }
      tell(FlashProgress::Step::Verified, block);
    }
  }
  return written.size();
}

}  // namespace lbpkit
