// SPDX-License-Identifier: MIT
#include "remote/nv_store.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>

namespace lbpkit::model::remote {

namespace {
constexpr std::uint8_t kMagic[4] = {'L', 'B', 'N', 'V'};
// Slot record: magic(4) sequence(4, LE) length(2, LE) image(length) crc32(4, LE) over all before it.
// The first slot starts at offset 0, so every file this store ever wrote
// starts with the magic (or, after a power cut in its very first write, with
// a prefix of it): that is how a file is recognised as an EEPROM image.
constexpr std::size_t kOverhead = 4 + 4 + 2 + 4;
// The note beside the file naming who holds it; recognised by this first line.
constexpr std::string_view kOwnerTag = "lbpkit EEPROM owner: ";

void putLe(std::vector<std::uint8_t>& v, std::uint64_t x, int n) {
  for (int i = 0; i < n; ++i) v.push_back(static_cast<std::uint8_t>(x >> (8 * i)));
}
std::uint64_t getLe(const std::uint8_t* p, int n) {
  std::uint64_t x = 0;
  for (int i = 0; i < n; ++i) x |= static_cast<std::uint64_t>(p[i]) << (8 * i);
  return x;
}

// "12 345": sizes in messages people read.
// Built forwards, a digit at a time: GCC 12 at -O3 warns (-Wrestrict, a false
// positive: GCC bugs 105329, 105651) on string::insert into the digits.
std::string grouped(std::uint64_t n) {
  const std::string digits = std::to_string(n);
  std::string out;
  out.reserve(digits.size() + digits.size() / 3);
  for (std::size_t i = 0; i < digits.size(); ++i) {
    if (i != 0 && (digits.size() - i) % 3 == 0) out.push_back(' ');
    out.push_back(digits[i]);
  }
  return out;
}

// What a path is, for files the store will not use.
const char* kindOf(mode_t mode) {
  if (S_ISLNK(mode)) return "a symbolic link";
  if (S_ISDIR(mode)) return "a directory";
  if (S_ISFIFO(mode)) return "a FIFO";
  if (S_ISSOCK(mode)) return "a socket";
  if (S_ISCHR(mode)) return "a character device";
  if (S_ISBLK(mode)) return "a block device";
  return "not a regular file";
}

std::string notARegularFile(const std::string& path, mode_t mode) {
  if (S_ISLNK(mode)) return path + ": is a symbolic link; lbpkit will not follow it (name the file it points to)";
  return path + ": is " + kindOf(mode) + ", not an EEPROM image; lbpkit will not use it";
}

bool readAll(int fd, std::uint8_t* into, std::size_t count, std::size_t& got) {
  got = 0;
  while (got < count) {
    const ssize_t n = ::pread(fd, into + got, count - got, static_cast<off_t>(got));
    if (n < 0 && errno == EINTR) continue;
    if (n < 0) return false;
    if (n == 0) break;
    got += static_cast<std::size_t>(n);
  }
  return true;
}

bool writeAll(int fd, const std::uint8_t* from, std::size_t count, off_t offset) {
  std::size_t done = 0;
  while (done < count) {
    const ssize_t n = ::pwrite(fd, from + done, count - done, offset + static_cast<off_t>(done));
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) {
      if (n == 0) errno = ENOSPC;
      return false;
    }
    done += static_cast<std::size_t>(n);
  }
  return true;
}
}  // namespace

std::uint32_t crc32(std::span<const std::uint8_t> bytes) {
  std::uint32_t c = 0xFFFFFFFFU;
  for (auto b : bytes) {
    c ^= b;
    for (int i = 0; i < 8; ++i) c = (c & 1U) ? (c >> 1) ^ 0xEDB88320U : c >> 1;
  }
  return ~c;
}

NvStore::NvStore(std::size_t size, std::filesystem::path file, std::string owner, NvReporter report)
    : image_(size, 0xFF),
      file_(std::move(file)),
      owner_(std::move(owner)),
      report_(std::move(report)),
      memory_(2 * (size + kOverhead), 0xFF) {}

NvStore::~NvStore() {
  // The note goes first, while the lock still keeps the next owner out.
  if (ownerNote_) ::unlink(ownerFile().c_str());
  if (fd_ >= 0) ::close(fd_);  // releases the lock
}

std::size_t NvStore::slotBytes() const { return image_.size() + kOverhead; }

void NvStore::report(NvEvent::Kind kind, const std::string& message) const {
  if (report_) report_(NvEvent{kind, message});
}

void NvStore::refuse(std::string why) {
  refusal_ = std::move(why);
  error_ = refusal_;
  report(NvEvent::Kind::Refused, refusal_);
}

std::filesystem::path NvStore::ownerFile() const { return file_.string() + ".owner"; }

// Who holds the lock: the pid the kernel knows, and the note the holder left.
std::string NvStore::lockHolder(int fd) const {
  struct flock l{};
  l.l_type = F_WRLCK;
  l.l_whence = SEEK_SET;
  std::string pid = ::fcntl(fd, F_GETLK, &l) == 0 && l.l_type != F_UNLCK ? "pid " + std::to_string(l.l_pid) : "";
  std::string who;
  const int note = ::open(ownerFile().c_str(), O_RDONLY | O_NOFOLLOW | O_NONBLOCK | O_CLOEXEC | O_NOCTTY);
  if (note >= 0) {
    struct stat st{};
    char text[256] = {};
    std::size_t got = 0;
    if (::fstat(note, &st) == 0 && S_ISREG(st.st_mode) &&
        readAll(note, reinterpret_cast<std::uint8_t*>(text), sizeof text - 1, got)) {
      const std::string_view s(text, got);
      if (s.starts_with(kOwnerTag)) {
        for (char c : s.substr(kOwnerTag.size())) {
          if (c == '\n') break;
          who.push_back(c >= ' ' && c < 0x7F ? c : '?');  // the note is another process's text
        }
      }
    }
    ::close(note);
  }
  if (who.empty()) return pid.empty() ? "holder unknown" : pid;
  return pid.empty() ? who : who + ", " + pid;
}

// Opens the file once for the store's life. Nothing is written to a file
// that is not already an EEPROM image (or empty, or new).
bool NvStore::open() {
  if (opened_) return fd_ >= 0;
  opened_ = true;
  const std::string path = file_.string();
  // Look before opening: opening a device or a FIFO can block or act.
  struct stat st{};
  if (::lstat(path.c_str(), &st) == 0 && !S_ISREG(st.st_mode)) {
    refuse(notARegularFile(path, st.st_mode));
    return false;
  }
  // O_NOFOLLOW and O_NONBLOCK again: the path may change between the look and the open.
  constexpr int kFlags = O_NOFOLLOW | O_NONBLOCK | O_CLOEXEC | O_NOCTTY;
  std::string readOnly;
  int fd = ::open(path.c_str(), O_RDWR | O_CREAT | kFlags, 0644);
  if (fd < 0 && (errno == EACCES || errno == EROFS || errno == EPERM)) {
    readOnly = std::strerror(errno);
    fd = ::open(path.c_str(), O_RDONLY | kFlags);
  }
  if (fd < 0) {
    const int e = errno;
    const auto dir = file_.parent_path();
    std::error_code ec;
    if (::lstat(path.c_str(), &st) == 0 && !S_ISREG(st.st_mode))
      refuse(notARegularFile(path, st.st_mode));
    else if (e == ENOENT && !dir.empty() && !std::filesystem::is_directory(dir, ec))
      refuse("cannot create " + path + ": directory " + dir.string() + " does not exist");
    else
      refuse("cannot open " + path + ": " + std::strerror(e));
    return false;
  }
  if (::fstat(fd, &st) != 0 || !S_ISREG(st.st_mode)) {
    ::close(fd);
    refuse(notARegularFile(path, st.st_mode));
    return false;
  }
  // Ours: empty (new), or starting with the magic (a prefix of it after a
  // power cut in the first write). Anything else is somebody's file.
  if (st.st_size > 0) {
    std::uint8_t head[sizeof kMagic] = {};
    std::size_t got = 0;
    const std::size_t want = std::min<std::size_t>(sizeof kMagic, static_cast<std::size_t>(st.st_size));
    if (!readAll(fd, head, want, got) || got != want || !std::equal(head, head + want, std::begin(kMagic))) {
      ::close(fd);
      refuse(path + ": is not an lbpkit EEPROM image (" + grouped(static_cast<std::uint64_t>(st.st_size)) +
             " bytes of something else); refusing to overwrite it");
      return false;
    }
  }
  // One writer at a time: two processes alternating slots would each
  // overwrite the other's newest image. The lock lives as long as fd does.
  struct flock l{};
  l.l_type = readOnly.empty() ? F_WRLCK : F_RDLCK;
  l.l_whence = SEEK_SET;
  if (::fcntl(fd, F_SETLK, &l) != 0) {
    const std::string holder = lockHolder(fd);
    ::close(fd);
    refuse(path + ": in use by another lbpkit (" + holder + "); each one needs an EEPROM file of its own");
    return false;
  }
  fd_ = fd;
  writable_ = readOnly.empty();
  if (!writable_) {
    readOnly_ = "cannot write " + path + ": " + readOnly;
    error_ = readOnly_;
    report(NvEvent::Kind::ReadOnly, path + ": read only (" + readOnly +
                                        "): the parameters load from it, but writes to the EEPROM will be refused");
  }
  if (writable_ && !owner_.empty()) {
    // The note is only ever written over if it is one of ours.
    const int note = ::open(ownerFile().c_str(), O_RDWR | O_CREAT | kFlags, 0644);
    if (note >= 0) {
      struct stat ns{};
      char head[kOwnerTag.size()] = {};
      std::size_t got = 0;
      const bool ours = ::fstat(note, &ns) == 0 && S_ISREG(ns.st_mode) &&
                        (ns.st_size == 0 || (readAll(note, reinterpret_cast<std::uint8_t*>(head), sizeof head, got) &&
                                             std::string_view(head, got) == kOwnerTag));
      if (ours) {
        const std::string text = std::string(kOwnerTag) + owner_ + "\n";
        ownerNote_ = ::ftruncate(note, 0) == 0 &&
                     writeAll(note, reinterpret_cast<const std::uint8_t*>(text.data()), text.size(), 0);
      }
      ::close(note);
    }
  }
  return true;
}

std::vector<std::uint8_t> NvStore::encodeSlot(std::uint32_t sequence, std::span<const std::uint8_t> image) const {
  std::vector<std::uint8_t> v(std::begin(kMagic), std::end(kMagic));
  putLe(v, sequence, 4);
  putLe(v, image.size(), 2);
  v.insert(v.end(), image.begin(), image.end());
  putLe(v, crc32(v), 4);
  return v;
}

std::optional<std::uint32_t> NvStore::decodeSlot(std::span<const std::uint8_t> slot,
                                                 std::vector<std::uint8_t>& out) const {
  if (slot.size() < kOverhead || !std::equal(std::begin(kMagic), std::end(kMagic), slot.begin())) return std::nullopt;
  const auto length = static_cast<std::size_t>(getLe(slot.data() + 8, 2));
  if (length != image_.size() || slot.size() < length + kOverhead) return std::nullopt;
  const auto stored = static_cast<std::uint32_t>(getLe(slot.data() + 10 + length, 4));
  if (crc32(slot.first(10 + length)) != stored) return std::nullopt;
  out.assign(slot.begin() + 10, slot.begin() + 10 + static_cast<std::ptrdiff_t>(length));
  return static_cast<std::uint32_t>(getLe(slot.data() + 4, 4));
}

bool NvStore::load() {
  std::vector<std::uint8_t> medium;
  if (file_.empty()) {
    medium = memory_;
  } else {
    if (!open()) {
      error_ = refusal_;
      return false;
    }
    medium.resize(2 * slotBytes());
    std::size_t got = 0;
    if (!readAll(fd_, medium.data(), medium.size(), got)) {
      error_ = "cannot read " + file_.string() + ": " + std::strerror(errno);
      report(NvEvent::Kind::Defaults, error_ + "; the processor starts from factory defaults");
      return false;
    }
    medium.resize(got);
    if (got == 0) {
      error_ = file_.string() + " is empty: a new EEPROM";
      return false;
    }
  }
  bool found = false;
  for (unsigned s = 0; s < 2; ++s) {
    const std::size_t begin = s * slotBytes();
    if (begin >= medium.size()) break;
    std::vector<std::uint8_t> candidate;
    auto seq = decodeSlot(std::span(medium).subspan(begin, std::min(slotBytes(), medium.size() - begin)), candidate);
    if (seq && (!found || newer(*seq, sequence_))) {
      found = true;
      sequence_ = *seq;
      newestSlot_ = s;
      image_ = std::move(candidate);
    }
  }
  if (!found) {
    error_ = file_.empty() ? "no stored image" : file_.string() + " holds no valid image";
    if (!file_.empty())
      report(NvEvent::Kind::Defaults, file_.string() + ": holds no valid EEPROM image (" + grouped(medium.size()) +
                                          " bytes, torn or corrupt); the processor starts from factory defaults");
  }
  return found;
}

bool NvStore::writeSlot(unsigned slot, std::span<const std::uint8_t> bytes) {
  std::size_t count = bytes.size();
  const bool cut = cutAfter_.has_value() && *cutAfter_ < count;
  lostPower_ = cut;
  if (cut) count = *cutAfter_;
  cutAfter_.reset();
  const std::size_t offset = slot * slotBytes();
  if (file_.empty()) {
    std::copy_n(bytes.begin(), count, memory_.begin() + static_cast<std::ptrdiff_t>(offset));
  } else {
    if (!open()) {
      error_ = refusal_;
      return false;
    }
    if (!writable_) {
      error_ = readOnly_;
      return false;
    }
    if (!writeAll(fd_, bytes.data(), count, static_cast<off_t>(offset)) || ::fsync(fd_) != 0) {
      error_ = "cannot write " + file_.string() + ": " + std::strerror(errno);
      return false;
    }
  }
  if (cut) {
    error_ = "power cut during EEPROM write";
    return false;
  }
  return true;
}

bool NvStore::commit(std::span<const std::uint8_t> image) {
  if (image.size() != image_.size()) {
    error_ = "image size mismatch";
    return false;
  }
  const unsigned target = 1 - newestSlot_;
  const auto record = encodeSlot(sequence_ + 1, image);  // wraps to 0 after 0xFFFFFFFF: newer() copes
  ++writes_;
  if (!writeSlot(target, record)) {
    // Every write that did not take is told, so that the user can see each one.
    if (!lostPower_) report(NvEvent::Kind::WriteFailed, "a write was not saved: " + error_);
    return false;
  }
  ++sequence_;
  newestSlot_ = target;
  image_.assign(image.begin(), image.end());
  return true;
}

}  // namespace lbpkit::model::remote
