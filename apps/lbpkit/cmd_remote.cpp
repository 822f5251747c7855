// SPDX-License-Identifier: MIT
// lbpkit remote: one virtual 7I77 processor on a serial face (a pty).
#include <fmt/core.h>

#include <filesystem>
#include <functional>
#include <memory>
#include <string>

#include "common.hpp"
#include "lbpkit/error.hpp"
#include "daemon/pcap_recorder.hpp"
#include "pty/pty_remote.hpp"
#include "remote/analog.hpp"
#include "remote/field_io.hpp"

// The layers' namespaces this file names (docs/architecture.md).
namespace app = lbpkit::app;
namespace remote = lbpkit::model::remote;
namespace server = lbpkit::server;

namespace lbpkit::app {
extern std::function<int()> gRun;
}

namespace {

struct RemoteOptions {
  bool pty = false;
  bool analog = false;
  bool setup = false;
  bool sinking = false;
  std::string state;
  std::string trace;  // --trace FILE.pcap: every LBP byte in and out, timed
};

int runRemote(const RemoteOptions& o) {
  if (!o.pty) {
    fmt::print(stderr, "lbpkit remote: say where to serve it: --pty (the only serial face so far)\n");
    return 2;
  }
  std::filesystem::path state = o.state;
  if (state.empty()) {
    state = app::defaultStateDir() / (o.analog ? "7i77-analog.eeprom" : "7i77-fieldio.eeprom");
    std::error_code ec;
    std::filesystem::create_directories(state.parent_path(), ec);  // lbpkit's own directory (a --state FILE's is not created)
  }
  // A file it will not use (not an EEPROM image, a symlink, held by another
  // lbpkit, ...) stops it before it starts: the checks the processor makes.
  {
    remote::NvStore probe(remote::memory::kEepromSize, state);
    probe.load();
    if (!probe.refusal().empty()) throw lbpkit::Error(probe.refusal());
  }
  // What the EEPROM file says (models cannot log): every refused write is logged.
  const auto owner = fmt::format("lbpkit remote --pty{}", o.analog ? " --analog" : "");
  auto report = [](const remote::NvEvent& e) {
    using Kind = remote::NvEvent::Kind;
    const bool error = e.kind == Kind::Refused || e.kind == Kind::WriteFailed;
    // fputs, not fmt::print: a log that cannot be written must not throw out of the serving loop.
    std::fputs(fmt::format("lbpkit remote: {}: {}{}\n", error ? "error" : "warning",
                           e.kind == Kind::NoProgram ? "" : "EEPROM: ", e.message)
                   .c_str(),
               stderr);
    std::fflush(stderr);
  };

  std::unique_ptr<remote::RemoteDevice> device;
  if (o.analog) {
    remote::AnalogProcessor::Options a;
    a.nvFile = state;
    a.nvOwner = owner;
    a.nvReport = report;
    a.setupMode = o.setup;
    device = std::make_unique<remote::AnalogProcessor>(a);
  } else {
    remote::FieldIoProcessor::Options f;
    f.outputs = o.sinking ? remote::OutputType::Sinking : remote::OutputType::Sourcing;
    f.nvFile = state;
    f.nvOwner = owner;
    f.nvReport = report;
    f.setupMode = o.setup;
    device = std::make_unique<remote::FieldIoProcessor>(f);
  }
  server::PtyRemote pty(*device);
  std::unique_ptr<server::PcapRecorder> trace;
  if (!o.trace.empty()) {
    trace = std::make_unique<server::PcapRecorder>(
        o.trace, server::PcapRecorder::Link::LbpStream,
        [](const std::string& text) { std::fputs(fmt::format("lbpkit remote: warning: {}\n", text).c_str(), stderr); });
    pty.setTrace(trace.get());
  }
  app::installSignalHandlers();
  fmt::print("lbpkit remote: virtual 7I77{} {} processor (unit 0x{:08X}), {} mode at {} baud\n",
             o.sinking && !o.analog ? "D" : "", o.analog ? "analog" : "field I/O", device->unitNumber(),
             o.setup ? "setup" : "operate", device->baud());
  fmt::print("  serial device: {}\n", pty.path());
  fmt::print("  EEPROM state:  {}\n", state.string());
  if (trace) fmt::print("  LBP trace:     {} (pcap; lbpkit decode reads it)\n", trace->path());
  fmt::print("  talk LBP to it as to a USB-RS422 adapter (e.g. lbpkit rpd FAULT H --serial {}); Ctrl-C stops it\n",
             pty.path());
  std::fflush(stdout);
  pty.run(app::gStop);
  fmt::print("lbpkit remote: stopped ({} bytes in, {} out, {} answer bytes no client read); EEPROM state in {}\n",
             pty.bytesIn(), pty.bytesOut(), pty.bytesDropped(), state.string());
  if (trace) {
    pty.setTrace(nullptr);
    const std::uint64_t lost = trace->dropped();
    trace.reset();  // writes the rest
    fmt::print("lbpkit remote: the LBP trace is in {}{}\n", o.trace,
               lost ? fmt::format(" ({} records lost: the writer fell behind)", lost) : std::string());
  }
  return 0;
}

}  // namespace

void addRemoteCommand(CLI::App& app) {
  auto o = std::make_shared<RemoteOptions>();
  auto* cmd = app.add_subcommand("remote", "Run one virtual 7I77 LBP processor on a serial face");
  cmd->add_flag("--pty", o->pty, "Serve it on a new pseudo-terminal and print its path");
  cmd->add_flag("--analog", o->analog, "The analog processor (channel 1) instead of field I/O");
  cmd->add_flag("--setup", o->setup, "Setup-mode jumper (W4/W12 right): 115.2 kBaud fixed");
  cmd->add_flag("--sinking", o->sinking, "7I77D: sinking field outputs");
  cmd->add_option("--state", o->state, "EEPROM file (non-volatile parameters)");
  cmd->add_option("--trace", o->trace, "pcap file: every LBP byte to and from the remote, timed (lbpkit decode)");
  cmd->callback([o] { app::gRun = [o] { return runRemote(*o); }; });
}
