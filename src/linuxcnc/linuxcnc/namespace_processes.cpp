// SPDX-License-Identifier: MIT
#include "linuxcnc/namespace_processes.hpp"

#include <sys/stat.h>

#include <cctype>
#include <fstream>
#include <iterator>

namespace lbpkit::linuxcnc {

namespace fs = std::filesystem;

unsigned long networkNamespaceOf(const fs::path& proc) {
  struct stat st {};
  return ::stat((proc / "ns/net").c_str(), &st) == 0 ? static_cast<unsigned long>(st.st_ino) : 0;
}

std::string commandOf(const fs::path& proc) {
  std::ifstream comm(proc / "comm");
  std::string c;
  std::getline(comm, c);
  return c;
}

void forEachProcessIn(unsigned long networkNamespace, const std::function<void(const fs::path&)>& f) {
  std::error_code ec;
  for (const auto& p : fs::directory_iterator("/proc", ec)) {
    const auto name = p.path().filename().string();
    if (name.empty() || std::isdigit(static_cast<unsigned char>(name[0])) == 0) continue;
    if (networkNamespaceOf(p.path()) == networkNamespace) f(p.path());
  }
}

bool errorWindowIsOpen(unsigned long networkNamespace) {
  bool open = false;
  forEachProcessIn(networkNamespace, [&](const fs::path& proc) {
    if (open || commandOf(proc).rfind("wish", 0) != 0) return;
    // The arguments, NUL-separated: the script is one of them.
    std::ifstream in(proc / "cmdline", std::ios::binary);
    const std::string cmdline((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    for (std::size_t at = 0; at < cmdline.size();) {
      const auto end = std::min(cmdline.find('\0', at), cmdline.size());
      if (fs::path(cmdline.substr(at, end - at)).filename() == "show_errors.tcl") open = true;
      at = end + 1;
    }
  });
  return open;
}

}  // namespace lbpkit::linuxcnc
