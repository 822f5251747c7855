#include "daemon/output_file.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <fmt/format.h>

#include <array>
#include <cerrno>
#include <cstring>
#include <stdexcept>

namespace servers {

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
  if (!S_ISREG(st.st_mode)) throw fail("not a regular file (a FIFO, a device or a socket): an output goes to a file");
  for (const auto& p : own) {
    struct stat o {};
    if (!p.empty() && ::stat(p.c_str(), &o) == 0 && o.st_dev == st.st_dev && o.st_ino == st.st_ino)
      throw fail(fmt::format("is the sim's own {}: never written over", p.string()));
  }
  if (st.st_size > 0) {
    std::array<char, 64> head{};
    const auto n = ::pread(fd, head.data(), head.size(), 0);
    if (n < 0 || !kind(std::string_view(head.data(), static_cast<std::size_t>(n))))
      throw fail(
          "exists and is not what this option writes: remove it or name another file (an existing file is "
          "replaced only when it is the output of an earlier run)");
  }
  if (::ftruncate(fd, 0) != 0) throw fail(std::strerror(errno));
  ::fcntl(fd, F_SETFL, ::fcntl(fd, F_GETFL) & ~O_NONBLOCK);
  std::FILE* f = ::fdopen(fd, "w");
  if (f == nullptr) throw fail(std::strerror(errno));
  return f;
}

}  // namespace servers
