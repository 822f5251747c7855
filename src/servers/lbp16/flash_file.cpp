// SPDX-License-Identifier: MIT
#include "lbp16/flash_file.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <array>
#include <cerrno>
#include <cstring>

#include "remote/nv_store.hpp"

namespace lbpkit::server {

namespace {
constexpr std::array<char, 8> kMagic = {'L', 'B', 'F', 'L', 'A', 'S', 'H', '1'};
constexpr std::size_t kHeader = 16;  // magic, size, CRC-32

std::string why(const std::filesystem::path& file, const std::string& what) {
  return file.string() + ": " + what + (errno != 0 ? std::string(" (") + std::strerror(errno) + ")" : std::string());
}

void putLittle32(std::uint8_t* p, std::uint32_t v) {
  for (int i = 0; i < 4; ++i) p[i] = static_cast<std::uint8_t>(v >> (8 * i));
}
std::uint32_t getLittle32(const std::uint8_t* p) {
  return std::uint32_t{p[0]} | std::uint32_t{p[1]} << 8 | std::uint32_t{p[2]} << 16 | std::uint32_t{p[3]} << 24;
}

// The whole of n bytes through read() or write(), across short transfers
// and interruptions.
template <typename Transfer, typename Byte>
bool whole(Transfer transfer, int fd, Byte* p, std::size_t n) {
  while (n > 0) {
    const auto r = transfer(fd, p, n);
    if (r < 0 && errno == EINTR) continue;
    if (r <= 0) return false;
    p += r;
    n -= static_cast<std::size_t>(r);
  }
  return true;
}
bool readAll(int fd, std::uint8_t* p, std::size_t n) { return whole(::read, fd, p, n); }
bool writeAll(int fd, const std::uint8_t* p, std::size_t n) { return whole(::write, fd, p, n); }
}  // namespace

FlashFileLoad loadFlashFile(const std::filesystem::path& file, std::span<std::uint8_t> image) {
  FlashFileLoad r;
  struct stat st{};
  errno = 0;
  if (::lstat(file.c_str(), &st) != 0) {
    if (errno == ENOENT) return r;  // New: a blank part
    return {FlashFileLoad::Status::Refused, why(file, "cannot look at the flash file")};
  }
  errno = 0;
  if (!S_ISREG(st.st_mode))
    return {FlashFileLoad::Status::Refused,
            file.string() + ": not a regular file (a symbolic link, directory or device): not used as the flash file"};
  if (st.st_size == 0) return r;
  const int fd = ::open(file.c_str(), O_RDONLY | O_NOFOLLOW | O_NONBLOCK | O_CLOEXEC | O_NOCTTY);
  if (fd < 0) return {FlashFileLoad::Status::Refused, why(file, "cannot open the flash file")};
  std::array<std::uint8_t, kHeader> h{};
  const bool header = static_cast<std::size_t>(st.st_size) >= kHeader && readAll(fd, h.data(), h.size());
  if (!header || std::memcmp(h.data(), kMagic.data(), kMagic.size()) != 0) {
    ::close(fd);
    errno = 0;
    return {FlashFileLoad::Status::Refused,
            file.string() + ": not an lbpkit flash image (it does not start with LBFLASH1): not used, not written over"};
  }
  const std::uint32_t size = getLittle32(&h[8]);
  const std::uint32_t crc = getLittle32(&h[12]);
  std::vector<std::uint8_t> data;
  if (size == image.size() && static_cast<std::uint64_t>(st.st_size) == kHeader + size) {
    data.resize(size);
    if (!readAll(fd, data.data(), data.size())) data.clear();
  }
  ::close(fd);
  errno = 0;
  if (data.size() != image.size())
    return {FlashFileLoad::Status::Corrupt,
            file.string() + ": the flash image is not " + std::to_string(image.size()) + " bytes: the flash starts blank"};
  if (model::remote::crc32(data) != crc)
    return {FlashFileLoad::Status::Corrupt, file.string() + ": the flash image's CRC is wrong: the flash starts blank"};
  std::memcpy(image.data(), data.data(), image.size());
  r.status = FlashFileLoad::Status::Loaded;
  return r;
}

std::string saveFlashFile(const std::filesystem::path& file, std::span<const std::uint8_t> image) {
  const auto tmp = file.string() + ".tmp";
  std::array<std::uint8_t, kHeader> h{};
  std::memcpy(h.data(), kMagic.data(), kMagic.size());
  putLittle32(&h[8], static_cast<std::uint32_t>(image.size()));
  putLittle32(&h[12], model::remote::crc32(image));
  errno = 0;
  struct stat st{};
  if (::lstat(file.c_str(), &st) == 0 && !S_ISREG(st.st_mode))
    return file.string() + ": not a regular file: not written";
  ::unlink(tmp.c_str());  // a leftover of a save cut short (never a file of the user's: it would be replaced anyway)
  const int fd = ::open(tmp.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_NOFOLLOW | O_CLOEXEC | O_NOCTTY, 0644);
  if (fd < 0) return why(tmp, "cannot create");
  const bool ok = writeAll(fd, h.data(), h.size()) && writeAll(fd, image.data(), image.size()) && ::fsync(fd) == 0;
  const std::string error = ok ? "" : why(tmp, "cannot write");
  ::close(fd);
  if (!ok) {
    ::unlink(tmp.c_str());
    return error;
  }
  // The new image replaces the old one whole: a cut before this leaves the
  // old file, after it the new one.
  if (::rename(tmp.c_str(), file.c_str()) != 0) {
    const auto e = why(file, "cannot replace");
    ::unlink(tmp.c_str());
    return e;
  }
  auto dir = file.parent_path();
  if (dir.empty()) dir = ".";
  const int d = ::open(dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (d >= 0) {
    ::fsync(d);  // the rename itself reaches the disk
    ::close(d);
  }
  return "";
}

FlashSaver::FlashSaver(std::filesystem::path file, Snapshot snapshot, std::chrono::milliseconds quiet,
                       std::chrono::milliseconds longest)
    : file_(std::move(file)), snapshot_(std::move(snapshot)), quiet_(quiet), longest_(longest) {
  thread_ = std::thread([this] { run(); });
}

FlashSaver::~FlashSaver() {
  {
    std::lock_guard<std::mutex> l(mutex_);
    stop_ = true;
  }
  cv_.notify_all();
  thread_.join();  // run() saves what is left before it returns
}

void FlashSaver::changed() {
  {
    std::lock_guard<std::mutex> l(mutex_);
    ++changes_;
  }
  cv_.notify_all();
}

std::string FlashSaver::lastError() const {
  std::lock_guard<std::mutex> l(mutex_);
  return error_;
}

std::uint64_t FlashSaver::saves() const {
  std::lock_guard<std::mutex> l(mutex_);
  return saves_;
}

void FlashSaver::saveLocked(std::unique_lock<std::mutex>& lock) {
  saved_ = changes_;
  lock.unlock();
  snapshot_(copy_);  // under the owner's lock: a consistent image
  const auto error = saveFlashFile(file_, copy_);
  lock.lock();
  error_ = error;
  ++saves_;
}

void FlashSaver::run() {
  std::unique_lock<std::mutex> l(mutex_);
  while (true) {
    cv_.wait(l, [&] { return stop_ || changes_ != saved_; });
    if (stop_) break;
    // Wait for the writes to pause (mesaflash programs page after page),
    // but not forever.
    const auto first = std::chrono::steady_clock::now();
    while (!stop_ && std::chrono::steady_clock::now() - first < longest_) {
      const auto seen = changes_;
      if (!cv_.wait_for(l, quiet_, [&] { return stop_ || changes_ != seen; })) break;  // quiet
    }
    if (changes_ != saved_) saveLocked(l);
  }
  if (changes_ != saved_) saveLocked(l);
}

}  // namespace lbpkit::server
