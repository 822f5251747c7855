// SPDX-License-Identifier: MIT
// The remote processor's EEPROM: non-volatile parameters that survive power
// cycles (manual: NON-VOLATILE FIELD I/O PARAMETERS).
//
// A power cut at any moment of a write leaves the old or the new image, never
// a mix: the image is kept in two slots, each with a sequence number and a
// CRC-32, and a write always goes to the slot that does not hold the newest
// good image. Loading takes the good slot with the newest sequence number
// (compared with wrap-around, so the write after 0xFFFFFFFF still wins).
// With no file the store lives in memory (tests, throw-away simulations).
//
// The file is the user's: the store opens it once, never through a symbolic
// link, only if it is a regular file that is empty or already an EEPROM
// image (every slot starts with the magic "LBNV"), and holds a lock on it for
// its whole life so that two processes never interleave their writes. A file
// it will not use is never written; the store then keeps the image in memory
// and refuses every write, and says why (refusal()).
#pragma once

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

namespace lbpkit::model::remote {

// What the store has to tell whoever runs the model (models do not log; the
// application prints these).
struct NvEvent {
  enum class Kind {
    Refused,      // the file is not used (not an image, a symlink, locked, ...); nothing is written to it
    Defaults,     // the file holds no readable image: the processor starts from factory defaults
    ReadOnly,     // the file can be read but not written: every write will be refused
    WriteFailed,  // a write did not reach the file (the processor refuses it to the host: LBP Invalid write)
    NoProgram,    // at power-up the program flash (program_flash.hpp) holds no valid program: only the boot block runs
  };
  Kind kind;
  std::string message;
};
using NvReporter = std::function<void(const NvEvent&)>;

class NvStore {
 public:
  // `owner` says who holds the file (e.g. "lbpkit sim on 127.0.0.1:27181");
  // it is kept beside the file while the store lives, so a second user is
  // told whom it is waiting for. `report` receives what the store cannot
  // hide from its user.
  explicit NvStore(std::size_t size, std::filesystem::path file = {}, std::string owner = {},
                   NvReporter report = {});
  ~NvStore();
  NvStore(const NvStore&) = delete;
  NvStore& operator=(const NvStore&) = delete;

  // Reads the newest good image from the file. Returns false (and leaves the
  // image as it was) when the file is new, unusable or holds no good slot.
  bool load();
  // Makes `image` the stored image, atomically with respect to power cuts.
  // Returns false when the medium refused the write (see lastError()).
  bool commit(std::span<const std::uint8_t> image);

  [[nodiscard]] std::span<const std::uint8_t> image() const { return image_; }
  [[nodiscard]] std::size_t size() const { return image_.size(); }
  [[nodiscard]] const std::filesystem::path& file() const { return file_; }
  [[nodiscard]] const std::string& lastError() const { return error_; }
  // Why the file is not used (empty while it is, or before it was opened).
  [[nodiscard]] const std::string& refusal() const { return refusal_; }
  [[nodiscard]] std::uint32_t writes() const { return writes_; }
  // The last commit failed because power went away mid-write (fault
  // injection), rather than because the file could not be written.
  [[nodiscard]] bool lostPower() const { return lostPower_; }

  // Fault injection for tests: the next commit loses power after this many
  // bytes of its slot record reached the medium (the rest is never written).
  void cutPowerAfter(std::size_t bytes) { cutAfter_ = bytes; }

  [[nodiscard]] std::size_t slotBytes() const;

  // Wrap-around ("serial number") order of slot sequence numbers: a is newer
  // than b when it is less than half the number space ahead of it.
  static bool newer(std::uint32_t a, std::uint32_t b) { return static_cast<std::int32_t>(a - b) > 0; }

 private:
  std::vector<std::uint8_t> encodeSlot(std::uint32_t sequence, std::span<const std::uint8_t> image) const;
  std::optional<std::uint32_t> decodeSlot(std::span<const std::uint8_t> slot, std::vector<std::uint8_t>& out) const;
  bool writeSlot(unsigned slot, std::span<const std::uint8_t> bytes);
  bool open();
  void refuse(std::string why);
  void report(NvEvent::Kind kind, const std::string& message) const;
  [[nodiscard]] std::filesystem::path ownerFile() const;
  [[nodiscard]] std::string lockHolder(int fd) const;

  std::vector<std::uint8_t> image_;
  std::filesystem::path file_;
  std::string owner_;
  NvReporter report_;
  int fd_ = -1;
  bool opened_ = false;    // open() has run (it runs once)
  bool writable_ = false;  // opened for writing (else read only, or refused)
  std::string readOnly_;    // why it was opened read only
  bool ownerNote_ = false;  // we wrote ownerFile()
  std::string refusal_;
  std::uint32_t sequence_ = 0;
  unsigned newestSlot_ = 1;  // the next commit goes to the other one
  std::string error_;
  std::uint32_t writes_ = 0;
  std::optional<std::size_t> cutAfter_;
  bool lostPower_ = false;
  std::vector<std::uint8_t> memory_;  // the medium when there is no file
};

std::uint32_t crc32(std::span<const std::uint8_t> bytes);

}  // namespace lbpkit::model::remote
