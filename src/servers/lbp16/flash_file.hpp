// SPDX-License-Identifier: MIT
// The 7I92's configuration flash kept in a file across runs, so that what
// `mesaflash --write` programmed is still there (and `--verify` matches)
// after `lbpkit sim` restarts.
//
// A save never leaves a half-written file: the image goes to FILE.tmp, is
// fsync'ed, renamed over FILE, and the directory is fsync'ed, so a power cut
// (or SIGKILL) at any moment leaves the old image or the new one. The file
// is "LBFLASH1", the image size and its CRC-32 (little endian), then the
// image. Like the EEPROM files, a file that is not such an image (or is a
// symbolic link, a directory, a device) is refused and never written over;
// an image whose size or CRC is wrong is reported and the flash starts blank.
#pragma once

#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <mutex>
#include <span>
#include <string>
#include <thread>
#include <vector>

namespace lbpkit::server {

struct FlashFileLoad {
  enum class Status {
    Loaded,   // the image was read into the flash
    New,      // no file, or an empty one: the flash starts blank
    Corrupt,  // an lbpkit flash image of the wrong size or CRC: the flash starts blank (say so)
    Refused,  // not an lbpkit flash image, or not a regular file: do not use it
  };
  Status status = Status::New;
  std::string message;  // why, for Corrupt and Refused (names the file)
};

// Reads FILE into `image` (which keeps its content unless Loaded).
FlashFileLoad loadFlashFile(const std::filesystem::path& file, std::span<std::uint8_t> image);
// Writes `image` to FILE as described above. Returns an empty string, or
// what went wrong (naming the file).
std::string saveFlashFile(const std::filesystem::path& file, std::span<const std::uint8_t> image);

// Saves a flash image off the caller's thread: changed() is cheap (a short
// lock and a notify, no allocation, no I/O), and a thread of its own copies
// the image (through `snapshot`, which must take the owner's lock) and
// saves it once changes have paused for `quiet` (or at least every
// `longest` while they go on), and once more when it is destroyed.
class FlashSaver {
 public:
  using Snapshot = std::function<void(std::vector<std::uint8_t>& into)>;
  FlashSaver(std::filesystem::path file, Snapshot snapshot, std::chrono::milliseconds quiet = std::chrono::milliseconds(200),
             std::chrono::milliseconds longest = std::chrono::seconds(2));
  ~FlashSaver();
  FlashSaver(const FlashSaver&) = delete;
  FlashSaver& operator=(const FlashSaver&) = delete;

  void changed();
  [[nodiscard]] const std::filesystem::path& file() const { return file_; }
  // The last save's error ("" when it worked), and how many saves were made.
  [[nodiscard]] std::string lastError() const;
  [[nodiscard]] std::uint64_t saves() const;

 private:
  void run();
  void saveLocked(std::unique_lock<std::mutex>& lock);

  std::filesystem::path file_;
  Snapshot snapshot_;
  std::chrono::milliseconds quiet_, longest_;
  mutable std::mutex mutex_;
  std::condition_variable cv_;
  std::uint64_t changes_ = 0;  // changed() calls
  std::uint64_t saved_ = 0;    // changes_ when the last save began
  std::uint64_t saves_ = 0;
  std::string error_;
  bool stop_ = false;
  std::vector<std::uint8_t> copy_;
  std::thread thread_;
};

}  // namespace lbpkit::server
