#include "remote/nv_store.hpp"

#include <fcntl.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>

namespace remote {

namespace {
constexpr std::uint8_t kMagic[4] = {'L', 'B', 'N', 'V'};
// Slot record: magic(4) sequence(4, LE) length(2, LE) image(length) crc32(4, LE) over all before it.
constexpr std::size_t kOverhead = 4 + 4 + 2 + 4;

void putLe(std::vector<std::uint8_t>& v, std::uint64_t x, int n) {
  for (int i = 0; i < n; ++i) v.push_back(static_cast<std::uint8_t>(x >> (8 * i)));
}
std::uint64_t getLe(const std::uint8_t* p, int n) {
  std::uint64_t x = 0;
  for (int i = 0; i < n; ++i) x |= static_cast<std::uint64_t>(p[i]) << (8 * i);
  return x;
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

NvStore::NvStore(std::size_t size, std::filesystem::path file)
    : image_(size, 0xFF), file_(std::move(file)), memory_(2 * (size + kOverhead), 0xFF) {}

std::size_t NvStore::slotBytes() const { return image_.size() + kOverhead; }

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
    const int fd = ::open(file_.c_str(), O_RDONLY | O_CLOEXEC);
    if (fd < 0) {
      error_ = "cannot open " + file_.string() + ": " + std::strerror(errno);
      return false;
    }
    medium.resize(2 * slotBytes());
    const ssize_t n = ::pread(fd, medium.data(), medium.size(), 0);
    ::close(fd);
    medium.resize(n > 0 ? static_cast<std::size_t>(n) : 0);
  }
  bool found = false;
  for (unsigned s = 0; s < 2; ++s) {
    const std::size_t begin = s * slotBytes();
    if (begin >= medium.size()) break;
    std::vector<std::uint8_t> candidate;
    auto seq = decodeSlot(std::span(medium).subspan(begin, std::min(slotBytes(), medium.size() - begin)), candidate);
    if (seq && (!found || *seq > sequence_)) {
      found = true;
      sequence_ = *seq;
      newestSlot_ = s;
      image_ = std::move(candidate);
    }
  }
  if (!found) error_ = file_.empty() ? "no stored image" : file_.string() + " holds no valid image";
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
    const int fd = ::open(file_.c_str(), O_WRONLY | O_CREAT | O_CLOEXEC, 0644);
    if (fd < 0) {
      error_ = "cannot write " + file_.string() + ": " + std::strerror(errno);
      return false;
    }
    const ssize_t n = ::pwrite(fd, bytes.data(), count, static_cast<off_t>(offset));
    const bool synced = ::fsync(fd) == 0;
    ::close(fd);
    if (n != static_cast<ssize_t>(count) || !synced) {
      error_ = "short write to " + file_.string() + ": " + std::strerror(errno);
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
  const auto record = encodeSlot(sequence_ + 1, image);
  ++writes_;
  if (!writeSlot(target, record)) return false;
  ++sequence_;
  newestSlot_ = target;
  image_.assign(image.begin(), image.end());
  return true;
}

}  // namespace remote
