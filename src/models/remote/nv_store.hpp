// The remote processor's EEPROM: non-volatile parameters that survive power
// cycles (manual: NON-VOLATILE FIELD I/O PARAMETERS).
//
// A power cut at any moment of a write leaves the old or the new image, never
// a mix: the image is kept in two slots, each with a sequence number and a
// CRC-32, and a write always goes to the slot that does not hold the newest
// good image. Loading takes the good slot with the highest sequence number.
// With no file the store lives in memory (tests, throw-away simulations).
#pragma once

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <optional>
#include <span>
#include <string>
#include <vector>

namespace remote {

class NvStore {
 public:
  explicit NvStore(std::size_t size, std::filesystem::path file = {});

  // Reads the newest good image from the file. Returns false (and leaves the
  // image as it was) when the file is missing or holds no good slot.
  bool load();
  // Makes `image` the stored image, atomically with respect to power cuts.
  // Returns false when the medium refused the write (see lastError()).
  bool commit(std::span<const std::uint8_t> image);

  [[nodiscard]] std::span<const std::uint8_t> image() const { return image_; }
  [[nodiscard]] std::size_t size() const { return image_.size(); }
  [[nodiscard]] const std::filesystem::path& file() const { return file_; }
  [[nodiscard]] const std::string& lastError() const { return error_; }
  [[nodiscard]] std::uint32_t writes() const { return writes_; }
  // The last commit failed because power went away mid-write (fault
  // injection), rather than because the file could not be written.
  [[nodiscard]] bool lostPower() const { return lostPower_; }

  // Fault injection for tests: the next commit loses power after this many
  // bytes of its slot record reached the medium (the rest is never written).
  void cutPowerAfter(std::size_t bytes) { cutAfter_ = bytes; }

  [[nodiscard]] std::size_t slotBytes() const;

 private:
  std::vector<std::uint8_t> encodeSlot(std::uint32_t sequence, std::span<const std::uint8_t> image) const;
  std::optional<std::uint32_t> decodeSlot(std::span<const std::uint8_t> slot, std::vector<std::uint8_t>& out) const;
  bool writeSlot(unsigned slot, std::span<const std::uint8_t> bytes);

  std::vector<std::uint8_t> image_;
  std::filesystem::path file_;
  std::uint32_t sequence_ = 0;
  unsigned newestSlot_ = 1;  // the next commit goes to the other one
  std::string error_;
  std::uint32_t writes_ = 0;
  std::optional<std::size_t> cutAfter_;
  bool lostPower_ = false;
  std::vector<std::uint8_t> memory_;  // the medium when there is no file
};

std::uint32_t crc32(std::span<const std::uint8_t> bytes);

}  // namespace remote
