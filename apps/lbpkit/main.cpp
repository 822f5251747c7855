// lbpkit: tools for the Mesa 7I77 system, real or virtual.
#include <CLI/CLI.hpp>
#include <fmt/core.h>

#include <atomic>
#include <csignal>
#include <cstdlib>
#include <filesystem>
#include <memory>

#include "net/pty_remote.hpp"
#include "remote/analog.hpp"
#include "remote/field_io.hpp"

namespace {

std::atomic<bool> gStop{false};
extern "C" void onSignal(int) { gStop.store(true); }

void installSignalHandlers() {
  struct sigaction sa{};
  sa.sa_handler = onSignal;
  sigemptyset(&sa.sa_mask);
  sigaction(SIGINT, &sa, nullptr);
  sigaction(SIGTERM, &sa, nullptr);
}

std::filesystem::path defaultStateDir() {
  if (const char* s = std::getenv("XDG_STATE_HOME"); s && *s) return std::filesystem::path(s) / "lbpkit";
  if (const char* h = std::getenv("HOME"); h && *h) return std::filesystem::path(h) / ".local/state/lbpkit";
  return std::filesystem::current_path() / ".lbpkit-state";
}

struct RemoteOptions {
  bool pty = false;
  bool analog = false;
  bool setup = false;
  bool sinking = false;
  std::string state;
};

int runRemote(const RemoteOptions& o) {
  if (!o.pty) {
    fmt::print(stderr, "lbpkit remote: say where to serve it: --pty (the only transport so far)\n");
    return 2;
  }
  std::filesystem::path state = o.state;
  if (state.empty()) state = defaultStateDir() / (o.analog ? "7i77-analog.eeprom" : "7i77-fieldio.eeprom");
  std::error_code ec;
  if (state.has_parent_path()) std::filesystem::create_directories(state.parent_path(), ec);

  std::unique_ptr<remote::RemoteDevice> device;
  if (o.analog) {
    device = std::make_unique<remote::AnalogProcessor>(remote::AnalogProcessor::Options{
        .unitNumber = 0x11000AEE, .nvFile = state, .setupMode = o.setup});
  } else {
    remote::FieldIoProcessor::Options f;
    f.outputs = o.sinking ? remote::OutputType::Sinking : remote::OutputType::Sourcing;
    f.nvFile = state;
    f.setupMode = o.setup;
    device = std::make_unique<remote::FieldIoProcessor>(f);
  }
  net::PtyRemote pty(*device);
  installSignalHandlers();
  fmt::print("lbpkit remote: virtual 7I77{} {} processor (unit 0x{:08X}), {} mode at {} baud\n",
             o.sinking && !o.analog ? "D" : "", o.analog ? "analog" : "field I/O", device->unitNumber(),
             o.setup ? "setup" : "operate", device->baud());
  fmt::print("  serial device: {}\n", pty.path());
  fmt::print("  EEPROM state:  {}\n", state.string());
  fmt::print("  talk LBP to it like a USB-RS422 adapter; Ctrl-C stops it\n");
  std::fflush(stdout);
  pty.run(gStop);
  fmt::print("lbpkit remote: stopped ({} bytes in, {} out); EEPROM state in {}\n", pty.bytesIn(), pty.bytesOut(),
             state.string());
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"lbpkit: the Mesa 7I77 servo/IO system, real or virtual"};
  app.require_subcommand(1);

  RemoteOptions remoteOptions;
  auto* remoteCmd = app.add_subcommand("remote", "Run one virtual 7I77 LBP processor on a serial face");
  remoteCmd->add_flag("--pty", remoteOptions.pty, "Serve it on a new pseudo-terminal and print its path");
  remoteCmd->add_flag("--analog", remoteOptions.analog, "The analog processor (channel 1) instead of field I/O");
  remoteCmd->add_flag("--setup", remoteOptions.setup, "Setup-mode jumper (W4/W12 right): 115.2 kBaud fixed");
  remoteCmd->add_flag("--sinking", remoteOptions.sinking, "7I77D: sinking field outputs");
  remoteCmd->add_option("--state", remoteOptions.state, "EEPROM file (non-volatile parameters)");

  CLI11_PARSE(app, argc, argv);
  try {
    if (remoteCmd->parsed()) return runRemote(remoteOptions);
  } catch (const std::exception& e) {
    fmt::print(stderr, "lbpkit: {}\n", e.what());
    return 1;
  }
  return 0;
}
