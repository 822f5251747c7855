// SPDX-License-Identifier: MIT
// An account of a test's own, for what a root command does for the user
// who ran sudo (SUDO_USER, SUDO_UID, SUDO_GID): made with useradd, its home
// a folder the test names, and removed with userdel when the test is done.
#pragma once

#include <grp.h>
#include <pwd.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <stdexcept>
#include <string>

#include "support/interop.hpp"

namespace test_support {

class TemporaryUser {
 public:
  explicit TemporaryUser(const std::filesystem::path& home) : name_("lbpkt" + std::to_string(::getpid())) {
    const auto made = interop::sh("useradd --system --user-group --no-create-home --shell /usr/sbin/nologin --home-dir " +
                                  home.string() + " " + name_);
    const passwd* pw = ::getpwnam(name_.c_str());
    if (made.exit != 0 || pw == nullptr) throw std::runtime_error("useradd " + name_ + ": " + made.out);
    uid_ = pw->pw_uid;
    gid_ = pw->pw_gid;
    std::filesystem::create_directories(home);
    if (::chown(home.c_str(), uid_, gid_) != 0) throw std::runtime_error("chown " + home.string());
  }
  ~TemporaryUser() { interop::sh("userdel " + name_); }
  TemporaryUser(const TemporaryUser&) = delete;
  TemporaryUser& operator=(const TemporaryUser&) = delete;

  [[nodiscard]] const std::string& name() const { return name_; }
  [[nodiscard]] uid_t uid() const { return uid_; }
  [[nodiscard]] gid_t gid() const { return gid_; }
  // SUDO_USER, SUDO_UID and SUDO_GID as sudo sets them for this user.
  void asSudoUser() const {
    ::setenv("SUDO_USER", name_.c_str(), 1);
    ::setenv("SUDO_UID", std::to_string(uid_).c_str(), 1);
    ::setenv("SUDO_GID", std::to_string(gid_).c_str(), 1);
  }

 private:
  std::string name_;
  uid_t uid_ = 0;
  gid_t gid_ = 0;
};

}  // namespace test_support
