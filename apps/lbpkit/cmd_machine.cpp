// SPDX-License-Identifier: MIT
// lbpkit machine --from-config CONFIG.ini [-o FILE.toml]: the machine file
// of the machine a LinuxCNC configuration expects (linuxcnc/machine_from_config.hpp),
// checked by loading it as lbpkit sim would.
#include <fmt/core.h>
#include <stdlib.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <functional>

#include "common.hpp"
#include "config/machine_toml.hpp"
#include "config/toml_reader.hpp"
#include "daemon/output_file.hpp"
#include "lbpkit/error.hpp"
#include "linuxcnc/machine_from_config.hpp"

// The layers' namespaces this file names (docs/architecture.md).
namespace app = lbpkit::app;
namespace server = lbpkit::server;
namespace config = lbpkit::config;

namespace lbpkit::app {
extern std::function<int()> gRun;

namespace {

// The machine file at `file` loaded as lbpkit sim loads it. Everything a
// configuration may say is checked as it is derived (the INI's file and
// line in each error), so a derived machine that does not load is lbpkit's
// fault; the message names the file it would have been (`shownAs`), not the
// temporary one.
void checkLoads(const std::string& file, const std::filesystem::path& ini, const std::string& shownAs) {
  try {
    (void)config::loadMachineFile(file);
  } catch (const std::exception& e) {
    std::string why = e.what();
    for (auto at = why.find(file); at != std::string::npos; at = why.find(file, at + shownAs.size()))
      why.replace(at, file.size(), shownAs);
    throw lbpkit::Error(fmt::format("the machine derived from {} does not load (a fault in lbpkit: the configuration "
                                    "passed every check of machine --from-config): {}",
                                    ini.string(), why));
  }
}

// The derived machine, its findings printed; an error when there is none.
std::string derive(const std::filesystem::path& ini) {
  const auto m = lbpkit::linuxcnc::machineFromConfig(ini);
  for (const auto& f : m.findings)
    fmt::print(stderr, "{}:{}: {}: {}\n", f.file, f.line, f.severity, f.reason);
  if (!m.ok() || m.toml.empty())
    throw lbpkit::Error(fmt::format("{}: no machine file: the errors above say what is missing", ini.string()));
  return m.toml;
}

}  // namespace

std::string deriveMachineFile(const std::filesystem::path& ini, const std::filesystem::path& out, bool force) {
  namespace fs = std::filesystem;
  const auto toml = derive(ini);
  // An existing file is replaced only when it is text no process holds
  // locked: never a running sim's EEPROM, its flash or another binary
  // state file, whatever --force says (daemon/output_file.hpp).
  try {
    server::checkReplaceable("-o", out.string(), server::isText);
  } catch (const std::runtime_error& e) {
    throw lbpkit::Error(e.what());
  }
  std::error_code ec;
  if (fs::exists(fs::symlink_status(out, ec)) && !force)
    throw lbpkit::Error(fmt::format("{}: exists; --force writes over it", out.string()));
  const auto folder = out.parent_path().empty() ? fs::path(".") : out.parent_path();
  if (!fs::is_directory(folder, ec))
    throw lbpkit::Error(fmt::format("-o {}: the folder {} does not exist", out.string(), folder.string()));
  // Written beside, checked as lbpkit sim reads it, then renamed over: the
  // file is the old one or the whole new one, never a part.
  const auto part = out.string() + fmt::format(".lbpkit-{}.part", ::getpid());
  {
    std::ofstream f(part, std::ios::trunc);
    f << toml;
    f.flush();
    if (!f) {
      fs::remove(part, ec);
      throw lbpkit::Error(fmt::format("-o {}: cannot write in {}", out.string(), folder.string()));
    }
  }
  try {
    checkLoads(part, ini, out.string());
  } catch (...) {
    fs::remove(part, ec);
    throw;
  }
  fs::rename(part, out);
  return toml;
}

}  // namespace lbpkit::app

namespace {

struct MachineOptions {
  std::string fromConfig;
  std::string output;
  bool force = false;
};

int runMachine(const MachineOptions& o) {
  if (!o.output.empty()) {
    app::deriveMachineFile(o.fromConfig, o.output, o.force);
    fmt::print(stderr, "lbpkit: wrote {} (lbpkit sim --machine {}; lbpkit linuxcnc {} --machine {})\n", o.output,
               o.output, o.fromConfig, o.output);
    return 0;
  }
  const auto toml = app::derive(o.fromConfig);
  // Checked as with -o, from a file of this process's own.
  std::string file = (std::filesystem::temp_directory_path() / "lbpkit-machine-XXXXXX").string();
  const int fd = ::mkstemp(file.data());
  if (fd < 0) throw lbpkit::Error(fmt::format("cannot create a file like {} to check the machine", file));
  struct Remove {
    std::string path;
    ~Remove() { ::unlink(path.c_str()); }
  } remove{file};
  const bool written = ::write(fd, toml.data(), toml.size()) == static_cast<ssize_t>(toml.size());
  ::close(fd);
  if (!written) throw lbpkit::Error(fmt::format("{}: cannot write", file));
  app::checkLoads(file, o.fromConfig, "(standard output)");
  fmt::print("{}", toml);
  return 0;
}

}  // namespace

void addMachineCommand(CLI::App& app) {
  auto o = std::make_shared<MachineOptions>();
  auto* cmd = app.add_subcommand("machine", "Machine files: the machine a LinuxCNC configuration expects");
  cmd->add_option("--from-config", o->fromConfig,
                  "The configuration's INI file: writes the machine it homes and runs on, each value's source beside "
                  "it")
      ->required();
  cmd->add_option("-o,--output", o->output, "Write it to FILE.toml (default: standard output)");
  cmd->add_flag("--force", o->force, "Write over an existing FILE.toml");
  cmd->callback([o] { app::gRun = [o] { return runMachine(*o); }; });
}
