// SPDX-License-Identifier: MIT
// libFuzzer target: the files a user hands lbpkit, each read by its own
// loader from what the fuzzer writes. The first byte picks the kind: a
// machine file (config::loadMachineFile), a fault script
// (config::loadFaultScript), or a LinuxCNC configuration, the rest split at
// the first NUL into its INI and its HAL file (linuxcnc::readConfiguration
// and machineFromConfig, as lbpkit check-config and lbpkit machine
// --from-config read them). Each must load or throw naming what was wrong:
// never crash, hang or grow without bound.
#include <unistd.h>

#include <cstdint>
#include <cstdlib>
#include <exception>
#include <filesystem>
#include <fstream>
#include <string>
#include <string_view>
#include <system_error>
#include <vector>

#include "config/fault_script.hpp"
#include "config/machine_toml.hpp"
#include "linuxcnc/hal_config.hpp"
#include "linuxcnc/machine_from_config.hpp"

// The layers' namespaces this file names (docs/architecture.md).
namespace config = lbpkit::config;

namespace {

// A folder of this process's own, in memory where the machine has one,
// made for each input and removed after it (libFuzzer may end the process
// without running exit handlers).
const std::filesystem::path& folder() {
  static const std::filesystem::path dir = [] {
    auto base = std::filesystem::exists("/dev/shm") ? std::filesystem::path("/dev/shm")
                                                    : std::filesystem::temp_directory_path();
    auto d = base / ("lbpkit-fuzz-config-" + std::to_string(::getpid()));
    return d;
  }();
  return dir;
}

std::string write(const std::string& name, std::string_view text) {
  const auto p = folder() / name;
  std::ofstream(p, std::ios::binary | std::ios::trunc).write(text.data(), static_cast<std::streamsize>(text.size()));
  return p.string();
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size == 0) return 0;
  const std::string_view text(reinterpret_cast<const char*>(data) + 1, size - 1);
  std::filesystem::create_directories(folder());
  try {
    switch (data[0] % 3) {
      case 0:
        (void)config::loadMachineFile(write("machine.toml", text));
        break;
      case 1:
        (void)config::loadFaultScript(write("faults.toml", text));
        break;
      default: {
        const auto split = text.find('\0');
        const auto ini = write("config.ini", text.substr(0, split));
        (void)write("config.hal", split == std::string_view::npos ? std::string_view() : text.substr(split + 1));
        std::vector<lbpkit::linuxcnc::Finding> findings;
        (void)lbpkit::linuxcnc::readConfiguration(ini, findings);
        (void)lbpkit::linuxcnc::machineFromConfig(ini);
        break;
      }
    }
  } catch (const std::exception&) {
    // A refusal, with its message: what a bad file should get.
  }
  std::error_code ec;
  std::filesystem::remove_all(folder(), ec);
  return 0;
}
