// SPDX-License-Identifier: MIT
#include "remote/program_flash.hpp"

#include <algorithm>
#include <stdexcept>

#include "lbp/protocol.hpp"

namespace lbpkit::model::remote {

namespace {

void putLe32(std::span<std::uint8_t> at, std::uint32_t v) {
  for (std::size_t i = 0; i < 4; ++i) at[i] = static_cast<std::uint8_t>(v >> (8 * i));
}

std::uint32_t le32(std::span<const std::uint8_t> at) {
  std::uint32_t v = 0;
  for (std::size_t i = 0; i < 4; ++i) v |= std::uint32_t{at[i]} << (8 * i);
  return v;
}

}  // namespace

std::vector<std::uint8_t> ProgramFlash::image(std::string_view cardName, std::uint8_t processor, std::uint8_t revision,
                                              std::span<const std::uint8_t> program) {
  if (program.size() > kSize - kProgramAt)
    throw std::invalid_argument("a program of " + std::to_string(program.size()) + " bytes does not fit the " +
                                std::to_string(kSize - kProgramAt) + " the flash has for it");
  // Block 0 (never written) zero, then the header and the program, the
  // rest of the last block erased.
  const std::size_t used = (kProgramAt + program.size() + kEraseBytes - 1) / kEraseBytes * kEraseBytes;
  std::vector<std::uint8_t> flash(used, 0xFF);
  std::fill_n(flash.begin(), kEraseBytes, std::uint8_t{0});
  std::span<std::uint8_t> header(flash.data() + kHeaderAt, kHeaderBytes);
  for (std::size_t i = 0; i < 4; ++i) header[i] = i < cardName.size() ? static_cast<std::uint8_t>(cardName[i]) : 0;
  header[4] = processor;
  header[5] = revision;
  header[6] = header[7] = 0;
  putLe32(header.subspan(8), static_cast<std::uint32_t>(program.size()));
  putLe32(header.subspan(12), crc32(program));
  std::copy(program.begin(), program.end(), flash.begin() + kProgramAt);
  return flash;
}

std::optional<std::uint8_t> ProgramFlash::programRevision(std::span<const std::uint8_t> contents,
                                                          std::string_view cardName, std::uint8_t processor) {
  if (contents.size() < kProgramAt) return std::nullopt;
  const auto header = contents.subspan(kHeaderAt, kHeaderBytes);
  for (std::size_t i = 0; i < 4; ++i)
    if (header[i] != (i < cardName.size() ? static_cast<std::uint8_t>(cardName[i]) : 0)) return std::nullopt;
  if (header[4] != processor || header[6] != 0 || header[7] != 0) return std::nullopt;
  const std::uint32_t length = le32(header.subspan(8));
  if (length > contents.size() - kProgramAt) return std::nullopt;
  if (crc32(contents.subspan(kProgramAt, length)) != le32(header.subspan(12))) return std::nullopt;
  return header[5];
}

ProgramFlash::ProgramFlash(std::filesystem::path file, std::string owner, NvReporter report)
    : report_(report),
      store_(kSize, std::move(file), std::move(owner), std::move(report)),
      flash_(kSize, 0xFF),
      page_(kWriteBytes, 0xFF) {}

void ProgramFlash::load(std::span<const std::uint8_t> factory) {
  if (store_.load()) {
    std::copy(store_.image().begin(), store_.image().end(), flash_.begin());
  } else {
    std::fill(flash_.begin(), flash_.end(), std::uint8_t{0xFF});
    std::copy_n(factory.begin(), std::min(factory.size(), flash_.size()), flash_.begin());
  }
  std::fill(page_.begin(), page_.end(), std::uint8_t{0xFF});
  offset_ = 0;
}

bool ProgramFlash::maps(std::uint16_t address) {
  return address < kWriteBytes || (address >= lbp::flash::kOffset && address <= lbp::flash::kCommit);
}

std::uint8_t ProgramFlash::read(std::uint16_t address) const {
  namespace f = lbp::flash;
  if (address < kWriteBytes) {
    const std::size_t at = std::size_t{offset_} + address;
    return at < flash_.size() ? flash_[at] : 0xFF;
  }
  if (address >= f::kOffset && address < f::kOffset + 4U)
    return static_cast<std::uint8_t>(offset_ >> (8 * (address - f::kOffset)));
  if (address == f::kEraseSize) return kEraseLog2;
  if (address == f::kWriteSize) return kWriteLog2;
  return 0;  // the commit register reads 0: the command is done when its reply comes
}

bool ProgramFlash::write(std::uint16_t address, std::uint8_t value) {
  namespace f = lbp::flash;
  if (address < kWriteBytes) {
    page_[address] = value;
    return true;
  }
  if (address >= f::kOffset && address < f::kOffset + 4U) {
    const unsigned shift = 8U * (address - f::kOffset);
    offset_ = (offset_ & ~(0xFFU << shift)) | (std::uint32_t{value} << shift);
    return true;
  }
  if (address == f::kCommit) return commit(value);
  return false;  // the sizes are read only
}

bool ProgramFlash::commit(std::uint8_t command) {
  namespace f = lbp::flash;
  const std::size_t unit = command == f::kErase ? kEraseBytes : command == f::kWrite ? kWriteBytes : 0;
  if (unit == 0 || offset_ % unit != 0 || offset_ < kEraseBytes || offset_ + unit > flash_.size()) return false;
  std::vector<std::uint8_t> next = flash_;
  if (command == f::kErase) {
    std::fill_n(next.begin() + offset_, unit, std::uint8_t{0xFF});
  } else {
    // Programming clears bits; it never sets one an erase has not.
    for (std::size_t i = 0; i < unit; ++i) next[offset_ + i] &= page_[i];
  }
  if (!store_.commit(next)) return false;
  flash_.swap(next);
  if (command == f::kErase) {
    ++erases_;
  } else {
    ++pageWrites_;
    std::fill(page_.begin(), page_.end(), std::uint8_t{0xFF});
  }
  return true;
}

}  // namespace lbpkit::model::remote
