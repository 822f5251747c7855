// SPDX-License-Identifier: MIT
// A folder of a test's own under the temporary directory, removed with
// everything in it when the test is done.
#pragma once

#include <stdlib.h>

#include <filesystem>
#include <stdexcept>
#include <string>
#include <system_error>

namespace test_support {

class TempDir {
 public:
  explicit TempDir(const std::string& prefix = "lbpkit-test") {
    std::string name = (std::filesystem::temp_directory_path() / (prefix + "-XXXXXX")).string();
    if (::mkdtemp(name.data()) == nullptr) throw std::runtime_error("cannot create a folder like " + name);
    path_ = name;
  }
  ~TempDir() {
    std::error_code ignored;
    std::filesystem::remove_all(path_, ignored);
  }
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;

  [[nodiscard]] const std::filesystem::path& path() const { return path_; }
  [[nodiscard]] std::string operator/(const std::string& name) const { return (path_ / name).string(); }

 private:
  std::filesystem::path path_;
};

// A sim's or a remote's state file and the files it keeps beside it
// (FILE.analog, FILE.program, FILE.analog.program, FILE.owner, ...): all
// removed, so that a test that names a state file of its own leaves none
// of them behind.
inline void removeStateFiles(const std::string& state) {
  const std::filesystem::path path(state);
  const auto name = path.filename().string();
  std::error_code ec;
  std::filesystem::remove(path, ec);
  const auto folder = path.parent_path().empty() ? std::filesystem::path(".") : path.parent_path();
  for (std::filesystem::directory_iterator it(folder, ec), end; !ec && it != end; it.increment(ec))
    if (it->path().filename().string().rfind(name + ".", 0) == 0) std::filesystem::remove(it->path(), ec);
}

}  // namespace test_support
