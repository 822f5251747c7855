// SPDX-License-Identifier: MIT
#include "daemon/output_file.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cerrno>
#include <cstring>
#include <stdexcept>

namespace lbpkit::server {

bool isCapture(std::string_view head) {
  if (head.size() < 4) return false;
  const std::string_view magic = head.substr(0, 4);
  // pcap's magic number 0xA1B2C3D4 (microseconds) or 0xA1B23C4D
  // (nanoseconds), in the writer's byte order.
  for (const std::string_view m : {std::string_view("\xA1\xB2\xC3\xD4", 4), std::string_view("\xD4\xC3\xB2\xA1", 4),
                                   std::string_view("\xA1\xB2\x3C\x4D", 4), std::string_view("\x4D\x3C\xB2\xA1", 4)})
    if (magic == m) return true;
  return false;
}

bool isRecord(std::string_view head) {
  return head.rfind("time_s,", 0) == 0 || head.rfind("time_s\n", 0) == 0 || head == "time_s";
}

bool isText(std::string_view head) {
  return std::none_of(head.begin(), head.end(), [](char c) {
    const auto b = static_cast<unsigned char>(c);
    return (b < 0x20 && b != '\t' && b != '\n' && b != '\r') || b == 0x7F;
  });
}

namespace {

// What may not become of the open file `fd` (a regular file, as fstat
// gave `st`): why not, or "".
std::string refusal(int fd, const struct stat& st, const OutputKind& kind, const std::vector<std::filesystem::path>& own) {
  if (!S_ISREG(st.st_mode)) return "not a regular file (a FIFO, a device or a socket): an output goes to a file";
  for (const auto& p : own) {
    struct stat o {};
    if (!p.empty() && ::stat(p.c_str(), &o) == 0 && o.st_dev == st.st_dev && o.st_ino == st.st_ino)
      return fmt::format("is the sim's own {}: never written over", p.string());
  }
  // A lock another process holds: a running sim's EEPROM (remote/nv_store.hpp).
  struct flock l {};
  l.l_type = F_WRLCK;
  l.l_whence = SEEK_SET;
  if (::fcntl(fd, F_GETLK, &l) == 0 && l.l_type != F_UNLCK)
    return fmt::format("is held locked by process {} (a running lbpkit's EEPROM): never written over", l.l_pid);
  if (st.st_size > 0) {
    std::array<char, 64> head{};
    const auto n = ::pread(fd, head.data(), head.size(), 0);
    if (n < 0 || !kind(std::string_view(head.data(), static_cast<std::size_t>(n))))
      return "exists and is not what this option writes: remove it or name another file (an existing file is "
             "replaced only when it is the output of an earlier run)";
  }
  return {};
}

}  // namespace

void checkReplaceable(const std::string& option, const std::string& path, const OutputKind& kind,
                      const std::vector<std::filesystem::path>& own) {
  auto refuse = [&](const std::string& why) { return std::runtime_error(fmt::format("{} {}: {}", option, path, why)); };
  struct stat st {};
  if (::lstat(path.c_str(), &st) != 0) {
    if (errno == ENOENT) return;
    throw refuse(std::strerror(errno));
  }
  if (S_ISLNK(st.st_mode)) throw refuse("a symbolic link: name the file itself (an output is never written through a link)");
  if (S_ISDIR(st.st_mode)) throw refuse("a directory: name a file");
  if (!S_ISREG(st.st_mode)) throw refuse("not a regular file (a FIFO, a device or a socket): an output goes to a file");
  const int fd = ::open(path.c_str(), O_RDONLY | O_NOFOLLOW | O_NONBLOCK | O_CLOEXEC);
  if (fd < 0) throw refuse(std::strerror(errno));
  std::string why = ::fstat(fd, &st) == 0 ? refusal(fd, st, kind, own) : std::string(std::strerror(errno));
  ::close(fd);
  if (!why.empty()) throw refuse(why);
}

std::FILE* openOutputFile(const std::string& option, const std::string& path, const OutputKind& kind,
                          const std::vector<std::filesystem::path>& own) {
  auto refuse = [&](const std::string& why) { return std::runtime_error(fmt::format("{} {}: {}", option, path, why)); };
  // O_NOFOLLOW: a link is refused, not followed; O_NONBLOCK: a FIFO with no
  // reader fails at once (ENXIO) instead of blocking, and one with a reader
  // is refused below.
  const int fd = ::open(path.c_str(), O_RDWR | O_CREAT | O_NOFOLLOW | O_NONBLOCK | O_CLOEXEC, 0644);
  if (fd < 0) {
    const int e = errno;
    if (e == ELOOP) throw refuse("a symbolic link: name the file itself (an output is never written through a link)");
    if (e == ENXIO) throw refuse("a FIFO, not a file: an output goes to a regular file");
    if (e == EISDIR) throw refuse("a directory: name a file");
    throw refuse(std::strerror(e));
  }
  auto fail = [&](const std::string& why) {
    ::close(fd);
    return refuse(why);
  };
  struct stat st {};
  if (::fstat(fd, &st) != 0) throw fail(std::strerror(errno));
  if (const auto why = refusal(fd, st, kind, own); !why.empty()) throw fail(why);
  if (::ftruncate(fd, 0) != 0) throw fail(std::strerror(errno));
  ::fcntl(fd, F_SETFL, ::fcntl(fd, F_GETFL) & ~O_NONBLOCK);
  std::FILE* f = ::fdopen(fd, "w");
  if (f == nullptr) throw fail(std::strerror(errno));
  return f;
}

}  // namespace lbpkit::server
