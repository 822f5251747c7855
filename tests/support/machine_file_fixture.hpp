// SPDX-License-Identifier: MIT
// Test helper: machine files written to a file of the test's own (named
// after the process, so parallel test processes do not meet), loaded, and
// removed afterwards.
#pragma once

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <string>
#include <utility>

#include "config/machine_toml.hpp"
#include "config/toml_reader.hpp"

namespace testing_config {

class MachineFileFixture : public testing::Test {
 protected:
  explicit MachineFileFixture(std::string name = "machine.toml") : name_(std::move(name)) {}
  void TearDown() override { std::filesystem::remove(path_); }
  // Writes `text` to the test's file (`name`, or the fixture's own) and says where.
  const std::string& write(const std::string& text, const std::string& name = {}) {
    std::filesystem::remove(path_);
    path_ = (std::filesystem::temp_directory_path() /
             ("lbpkit-" + std::to_string(::getpid()) + "-" + (name.empty() ? name_ : name)))
                .string();
    std::ofstream(path_) << text;
    return path_;
  }
  // The message loading `text` fails with ("" when it loads).
  std::string error(const std::string& text) {
    try {
      (void)lbpkit::config::loadMachine(write(text));
    } catch (const lbpkit::config::FileError& e) {
      return e.what();
    }
    return "";
  }
  std::string path_;

 private:
  std::string name_;
};

}  // namespace testing_config
