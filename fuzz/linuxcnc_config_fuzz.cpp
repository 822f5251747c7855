// SPDX-License-Identifier: MIT
// libFuzzer target: a LinuxCNC configuration as `sudo lbpkit linuxcnc`
// reads it, as root, from wherever it was downloaded. The input is the INI's
// file name (up to the first newline), then the INI and, after the first
// NUL, a HAL file named config.hal. Each goes through what lbpkit linuxcnc
// does with it: linuxcnc::checkConfig, then machineFromConfig, and a machine
// it derives is loaded as lbpkit sim loads it. Each must load or be refused
// with a message, never crash, hang or grow without bound; and a derived
// machine that does not load is a fault (abort): whatever the derivation
// accepts, the machine file must take.
#include <unistd.h>

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <filesystem>
#include <fstream>
#include <string>
#include <string_view>
#include <system_error>
#include <vector>

#include "config/machine_toml.hpp"
#include "linuxcnc/config_check.hpp"
#include "linuxcnc/machine_from_config.hpp"

// The layers' namespaces this file names (docs/architecture.md).
namespace config = lbpkit::config;

namespace {

// A folder of this process's own, in memory where the machine has one,
// emptied after each input.
const std::filesystem::path& folder() {
  static const std::filesystem::path dir = [] {
    const auto base = std::filesystem::exists("/dev/shm") ? std::filesystem::path("/dev/shm")
                                                          : std::filesystem::temp_directory_path();
    return base / ("lbpkit-fuzz-linuxcnc-" + std::to_string(::getpid()));
  }();
  return dir;
}

std::filesystem::path write(const std::string& name, std::string_view text) {
  const auto p = folder() / name;
  std::ofstream(p, std::ios::binary | std::ios::trunc).write(text.data(), static_cast<std::streamsize>(text.size()));
  return p;
}

// The INI's file name: any bytes a file name may hold (no '/', no NUL), at
// most 200, ending .ini as lbpkit linuxcnc needs.
std::string iniName(std::string_view given) {
  std::string name;
  for (const char c : given.substr(0, 200)) name += c == '/' || c == '\0' ? '_' : c;
  if (name.empty() || name == "." || name == "..") name = "config";
  return name + ".ini";
}

// No card: the checker's board model is lbpkit's catalogue in the CLI; here
// every board is one it does not know, so the reading and the derivation
// are what is driven.
std::vector<lbpkit::linuxcnc::Board> noBoard(const lbpkit::linuxcnc::Board&, const lbpkit::linuxcnc::Hm2Config&,
                                             unsigned, std::string& whyNot) {
  whyNot = "the fuzz target models no card";
  return {};
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view input(reinterpret_cast<const char*>(data), size);
  const auto newline = input.find('\n');
  if (newline == std::string_view::npos) return 0;
  const auto rest = input.substr(newline + 1);
  const auto split = rest.find('\0');
  std::error_code ec;
  std::filesystem::remove_all(folder(), ec);
  std::filesystem::create_directories(folder());
  const auto ini = write(iniName(input.substr(0, newline)), rest.substr(0, split));
  (void)write("config.hal", split == std::string_view::npos ? std::string_view() : rest.substr(split + 1));
  try {
    (void)lbpkit::linuxcnc::checkConfig(ini, noBoard);
  } catch (const std::exception&) {
    // A refusal, with its message.
  }
  lbpkit::linuxcnc::DerivedMachine m;
  try {
    m = lbpkit::linuxcnc::machineFromConfig(ini);
  } catch (const std::exception&) {
    m = {};
  }
  if (m.ok() && !m.toml.empty()) {
    const auto file = write("derived.toml", m.toml);
    try {
      (void)config::loadMachineFile(file.string());
    } catch (const std::exception& e) {
      std::fprintf(stderr, "a derived machine does not load: %s\n%s\n", e.what(), m.toml.c_str());
      std::abort();
    }
  }
  std::filesystem::remove_all(folder(), ec);
  return 0;
}
