// lbpkit machine --from-config CONFIG.ini [-o FILE.toml]: the machine file
// of the machine a LinuxCNC configuration expects (linuxcnc/machine_from_config.hpp),
// checked by loading it as lbpkit sim would.
#include <fmt/core.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <functional>

#include "common.hpp"
#include "config/machine_toml.hpp"
#include "config/toml_reader.hpp"
#include "lbpkit/error.hpp"
#include "linuxcnc/machine_from_config.hpp"

namespace app {
extern std::function<int()> gRun;

std::string deriveMachineFile(const std::filesystem::path& ini, const std::filesystem::path& out, bool force) {
  namespace fs = std::filesystem;
  const auto m = lbpkit::linuxcnc::machineFromConfig(ini);
  for (const auto& f : m.findings)
    fmt::print(stderr, "{}:{}: {}: {}\n", f.file, f.line, f.severity, f.reason);
  if (!m.ok() || m.toml.empty())
    throw lbpkit::Error(fmt::format("{}: no machine file: the errors above say what is missing", ini.string()));
  std::error_code ec;
  const auto status = fs::symlink_status(out, ec);
  if (fs::exists(status) && !fs::is_regular_file(status))
    throw lbpkit::Error(fmt::format("{}: not a regular file (a link, a folder, a FIFO): lbpkit writes only files",
                                    out.string()));
  if (fs::exists(status) && !force)
    throw lbpkit::Error(fmt::format("{}: exists; --force writes over it", out.string()));
  // Written beside, checked as lbpkit sim reads it, then renamed over: the
  // file is the old one or the whole new one, never a part.
  const auto part = out.string() + fmt::format(".lbpkit-{}.part", ::getpid());
  {
    std::ofstream f(part, std::ios::trunc);
    f << m.toml;
    f.flush();
    if (!f) throw lbpkit::Error(fmt::format("{}: cannot write", part));
  }
  try {
    (void)config::loadMachineFile(part);
  } catch (const std::exception& e) {
    fs::remove(part, ec);
    throw lbpkit::Error(fmt::format("the machine derived from {} does not load (a fault in lbpkit): {}", ini.string(),
                                    e.what()));
  }
  fs::rename(part, out);
  return m.toml;
}

}  // namespace app

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
  const auto m = lbpkit::linuxcnc::machineFromConfig(o.fromConfig);
  for (const auto& f : m.findings) fmt::print(stderr, "{}:{}: {}: {}\n", f.file, f.line, f.severity, f.reason);
  if (!m.ok() || m.toml.empty()) return 1;
  fmt::print("{}", m.toml);
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
