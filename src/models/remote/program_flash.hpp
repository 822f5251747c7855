// SPDX-License-Identifier: MIT
// A 7I77 processor's program flash, as a host reaches it over LBP with
// non-volatile access set to flash (local 0xEC = 2; LBP.INC) in setup mode
// (manual: RPD, WPD, AND UFLBP: "the 7I77 MUST be in setup mode"): what
// LinuxCNC's setsserial and Mesa's UFLBP use to update its firmware.
//
// Its registers, with NV access = flash (lbp::flash, LBP.INC):
//   0x8000..0x8003  offset: where the next erase or write goes (32 bits)
//   0x8004          erase block size, log2 (read only)
//   0x8005          write page size, log2 (read only)
//   0x8007          commit: 0xFE erases the block at the offset, 0xFD
//                   programs the page buffer at the offset
//   0x0000..        the page buffer (write page size bytes), over the RPC
//                   table's addresses: writes fill it; reads give the flash
//                   at offset + address (lbpkit's way to read an image back;
//                   no public source says how a real one is read)
// An erased byte is 0xFF and programming only clears bits, as in any NOR or
// microcontroller flash. Block 0 is the boot block that takes these
// commands (setsserial never writes it: its ReservedBlock); an erase or
// write there, unaligned or past the end is refused.
//
// No public source gives the 7I77 processors' flash geometry; lbpkit's
// choice is 32 KiB in 512-byte erase blocks and 64-byte pages. Nor is the
// format of Mesa's 7I77 .BIN files public: lbpkit's image (image()) is
// the whole flash, block 0 ignored, with a header at block 1 naming the
// card, the processor and the software revision, and a CRC-32 of the
// program. At power-up the processor runs the program when the header is
// its own and the CRC holds; otherwise (a foreign image, a flash stopped
// between an erase and its writes) only the boot block runs, which answers
// LBP and takes a new image in setup mode but has no process data.
//
// The flash is kept in a file of its own beside the EEPROM's (FILE.program)
// by an NvStore: a power cut at any moment leaves the whole flash as it was
// before the erase or write being committed, or after it. An update cut
// between two commits (the host gone, the power cut) leaves a flash whose
// program is not valid: the boot block runs at the next power-up, says so
// (NvEvent::Kind::NoProgram), and takes a new image.
#pragma once

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "lbpkit/wire/seven_i77.hpp"
#include "remote/nv_store.hpp"

namespace lbpkit::model::remote {

class ProgramFlash {
 public:
  static constexpr std::uint8_t kEraseLog2 = 9;
  static constexpr std::uint8_t kWriteLog2 = 6;
  static constexpr std::size_t kEraseBytes = std::size_t{1} << kEraseLog2;
  static constexpr std::size_t kWriteBytes = std::size_t{1} << kWriteLog2;
  static constexpr std::size_t kSize = lbpkit::wire::i7i77::kProgramFlashBytes;
  // The image header, at the start of block 1: card name (4 ASCII bytes),
  // processor (gtoc_parameters.hpp: kFieldIoProcessor or kAnalogProcessor),
  // software revision, two zero bytes, the program's length after the
  // header (32 bits) and its CRC-32 (32 bits), little-endian.
  static constexpr std::size_t kHeaderAt = kEraseBytes;
  static constexpr std::size_t kHeaderBytes = 16;
  static constexpr std::size_t kProgramAt = kHeaderAt + kHeaderBytes;

  // An image of a program for this processor, as a file for setsserial:
  // the flash from block 0 (zero: the boot block is not written) to the end
  // of the block the program ends in (erased bytes after it). Throws
  // std::invalid_argument when it does not fit.
  static std::vector<std::uint8_t> image(std::string_view cardName, std::uint8_t processor, std::uint8_t revision,
                                         std::span<const std::uint8_t> program);
  // The revision of the program `contents` holds for this processor, if it
  // holds one whose header and CRC-32 are good.
  static std::optional<std::uint8_t> programRevision(std::span<const std::uint8_t> contents,
                                                     std::string_view cardName, std::uint8_t processor);

  // `file` empty: in memory. `owner`, `report`: as NvStore's.
  explicit ProgramFlash(std::filesystem::path file = {}, std::string owner = {}, NvReporter report = {});

  // At power-up: the file's flash, or `factory` while the file holds none
  // (written to the file with the first erase or write).
  void load(std::span<const std::uint8_t> factory);
  // Whether `address` is one of the flash's while NV access is flash.
  [[nodiscard]] static bool maps(std::uint16_t address);
  [[nodiscard]] std::uint8_t read(std::uint16_t address) const;
  // False when refused: read-only, a bad commit (unaligned, past the end,
  // the boot block, an unknown command), or a file that did not take it.
  bool write(std::uint16_t address, std::uint8_t value);

  [[nodiscard]] std::span<const std::uint8_t> contents() const { return flash_; }
  [[nodiscard]] const NvStore& store() const { return store_; }
  NvStore& store() { return store_; }
  // Tells whoever runs the model (as NvStore's events): a model cannot log.
  void report(NvEvent::Kind kind, std::string message) const {
    if (report_) report_(NvEvent{kind, std::move(message)});
  }
  [[nodiscard]] std::uint32_t erases() const { return erases_; }
  [[nodiscard]] std::uint32_t pageWrites() const { return pageWrites_; }

 private:
  bool commit(std::uint8_t command);

  NvReporter report_;
  NvStore store_;
  std::vector<std::uint8_t> flash_;
  std::vector<std::uint8_t> page_;
  std::uint32_t offset_ = 0;
  std::uint32_t erases_ = 0;
  std::uint32_t pageWrites_ = 0;
};

}  // namespace lbpkit::model::remote
