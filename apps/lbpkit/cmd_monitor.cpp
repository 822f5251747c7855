// SPDX-License-Identifier: MIT
// lbpkit monitor: a live terminal view of a running 7I77: inputs, outputs,
// analog values, encoders and faults, cycling at the servo rate; and, when
// the card is an `lbpkit sim --machine`, the machine behind it (axes,
// switches, spindle) from the sim's control API.
#include <fmt/core.h>

#include <chrono>
#include <cmath>
#include <exception>
#include <functional>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "common.hpp"
#include "lbpkit/encoders.hpp"
#include "lbpkit/error.hpp"
#include "lbpkit/faults.hpp"
#include "lbpkit/lbp16_transport.hpp"
#include "lbpkit/servo_cycle.hpp"
#include "lbpkit/wire/seven_i77.hpp"
#include "machine_view.hpp"

// The layers' namespaces this file names (docs/architecture.md).
namespace app = lbpkit::app;
namespace hm2 = lbpkit::model::hm2;
namespace lbp = lbpkit::model::lbp;

namespace lbpkit::app {
extern std::function<int()> gRun;
}

namespace {

struct MonitorOptions {
  app::CardOptions card;
  double servoHz = 1000;
  double displayHz = 10;
  unsigned frames = 0;  // 0: until Ctrl-C
  double replyTimeoutMs =
      std::chrono::duration<double, std::milli>(lbpkit::Lbp16Transport::kDefaultCycleTimeout).count();
  bool demo = false;
  bool plain = false;  // no screen clearing (logs, tests)
  std::string api;     // [ADDR:]PORT of a sim's control API; "": the card's address, port 27182
  bool noApi = false;
  std::string apiToken;
};

// Where to ask for the machine: --api [ADDR:]PORT, else the card's address
// on the sim's default API port. The in-process card (--sim) has no sim
// behind it: asked only when --api names one.
std::unique_ptr<app::MachineWatcher> machineWatcher(const MonitorOptions& o) {
  if (o.noApi) return nullptr;
  const auto api = app::parseApiAddress(o.api, o.card.addr.substr(0, o.card.addr.find(':')));
  const std::string& host = api.host;
  const int port = api.port;
  if (host.empty()) return nullptr;
  // Once per screen, at most 20 times a second.
  const auto period = std::max(std::chrono::milliseconds(50),
                               std::chrono::milliseconds(static_cast<std::int64_t>(1000.0 / o.displayHz)));
  return std::make_unique<app::MachineWatcher>(host, port, o.apiToken, period);
}

// The ranges the options must be in, and why, for CLI11 to check before
// anything runs (a --rate of 1e9 once made a "frame" of 10^8 cycles that ran
// for minutes, deaf to Ctrl-C).
constexpr double kMinServoHz = 1, kMaxServoHz = 20000;
constexpr double kMinDisplayHz = 0.1, kMaxDisplayHz = 100;
constexpr unsigned kMaxFrames = 100'000'000;
constexpr double kMinReplyTimeoutMs = 0.05, kMaxReplyTimeoutMs = 1000;

CLI::Validator inRange(double lo, double hi, const std::string& unit, const std::string& why) {
  return CLI::Validator(
      [=](std::string& text) -> std::string {
        double v = 0;
        std::size_t used = 0;
        try {
          v = std::stod(text, &used);
        } catch (const std::exception&) {
          used = 0;
        }
        if (used != text.size() || !std::isfinite(v))
          return fmt::format("\"{}\" is not a number; give {} to {}{}", text, lo, hi, unit);
        if (v < lo || v > hi) return fmt::format("{} is out of range: give {} to {}{}{}", text, lo, hi, unit, why);
        return {};
      },
      fmt::format("{} to {}{}", lo, hi, unit));
}

// Waits until `until` in short steps, so a stop request is seen at once.
void sleepUnlessStopped(std::chrono::steady_clock::time_point until) {
  while (!app::gStop.load() && std::chrono::steady_clock::now() < until)
    std::this_thread::sleep_for(std::min<std::chrono::steady_clock::duration>(
        until - std::chrono::steady_clock::now(), std::chrono::milliseconds(20)));
}

std::string bitsText(std::uint64_t v, unsigned n) {
  std::string s;
  for (unsigned b = 0; b < n; ++b) {
    if (b && b % 8 == 0) s += ' ';
    s += ((v >> b) & 1U) ? '1' : '.';
  }
  return s;
}

int runMonitor(const MonitorOptions& o) {
  // Before the card: its first answer is fetched here, before any servo
  // cycle runs (the 7I77's watchdog must not wait for it).
  const auto watcher = machineWatcher(o);
  auto card = app::openCard(o.card);
  auto& t = *card.transport;
  if (auto* net = dynamic_cast<lbpkit::Lbp16Transport*>(&t))
    net->setCycleTimeout(std::chrono::duration_cast<lbpkit::Nanoseconds>(
        std::chrono::duration<double, std::milli>(o.replyTimeoutMs)));
  lbpkit::SmartSerial ss(t, card.info, o.card.serialOptions());
  ss.discover(o.card.serialOptions().channelMask);
  ss.startNormal();
  lbpkit::MuxedEncoders enc(t, card.info);
  enc.initialize();
  app::installSignalHandlers();

  const auto period = std::chrono::duration_cast<lbpkit::Nanoseconds>(std::chrono::duration<double>(1.0 / o.servoHz));
  const auto perFrame = std::max(1U, static_cast<unsigned>(o.servoHz / o.displayHz));
  const auto output = ss.find(0, "Output");
  const auto analog0 = ss.find(1, "AnalogOut0");
  const auto ena = ss.find(1, "AnalogEna");
  std::uint64_t failedCycles = 0, failedRecoveries = 0, watchdogBites = 0, watchdogRestarts = 0;
  // A channel whose remote reports its watchdog bit (this process held
  // back past the 7I77's 50 ms: a busy machine, a stall): the 7I77 has
  // turned its outputs off and keeps the fault until the channel starts
  // again (7I77 manual: FIELD I/O WATCHDOG AND FAULTS), so the monitor says
  // so, counts it and restarts the channel.
  std::vector<bool> bitten(ss.slots(), false);
  const auto wallStart = std::chrono::steady_clock::now();
  for (unsigned frame = 0; (o.frames == 0 || frame < o.frames) && !app::gStop.load(); ++frame) {
    // The stop flag is checked every cycle: a frame can be many cycles.
    for (unsigned c = 0; c < perFrame && !app::gStop.load(); ++c) {
      const auto start = t.now();
      const double seconds = std::chrono::duration<double>(start).count();
      if (o.demo) {
        // Drive the board: a walking output bit and a sine on analog 0. With
        // --sim, also the world: outputs wired back to the inputs and an
        // encoder turning at 10 000 counts/s (`lbpkit sim --demo` does the
        // same on the network).
        const auto walk = static_cast<unsigned>(seconds * 5) % 16;
        if (output.valid()) ss.setRaw(output, 1ULL << walk);
        if (analog0.valid()) ss.set(analog0, 5.0 * std::sin(seconds));
        if (ena.valid()) ss.setRaw(ena, 1);
        if (card.sim) {
          auto& board = card.sim->card().daughtercard(0);
          for (unsigned i = 0; i < 16; ++i) board.fieldIo.setInputVoltage(i, board.fieldIo.outputOn(i) ? 24.0 : 0.0);
          if (frame == 0 && c == 0) card.sim->card().part<hm2::MuxedEncoder>().setVelocity(0, 10000, lbp::SimTime{start});
        }
      }
      const auto st = lbpkit::servoCycle(t, ss, &enc);  // a lost reply shows in its status
      for (unsigned s = 0; s < ss.slots(); ++s) {
        const bool bite = (ss.remoteFaults(s) & lbpkit::wire::i7i77::fault::kWatchdog) != 0;
        if (bite && !bitten[s]) ++watchdogBites;
        bitten[s] = bite;
        if (!bite || !st.ok) continue;
        try {
          if (ss.recover(s)) ++watchdogRestarts;
        } catch (const lbpkit::Error&) {
          ++failedRecoveries;  // the next cycle tries again
        }
      }
      if (!st.ok) {
        ++failedCycles;
        for (unsigned s = 0; s < ss.slots(); ++s) {
          if (!(st.failedMask & (1U << ss.slotIdentity(s).channel))) continue;
          try {
            ss.recover(s);  // set-up commands: they throw when the card does not answer
          } catch (const lbpkit::Error&) {
            ++failedRecoveries;  // the link is lossy: the next failing cycle tries again
          }
        }
      }
      const auto spent = t.now() - start;
      if (spent < period) t.sleep(period - spent);
    }
    // Pace the virtual card to the wall clock.
    if (card.sim)
      sleepUnlessStopped(wallStart + std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                                         std::chrono::duration<double>((frame + 1) / o.displayHz)));

    const auto link = t.linkCounters();
    std::string screen = o.plain ? "" : "\x1b[H\x1b[2J";
    screen += fmt::format("lbpkit monitor: {} ({}), cycle {} at {:.0f} Hz, {} failed cycles, {} lost replies\n",
                          card.info.boardName, t.describe(), ss.cycles(), o.servoHz, failedCycles, link.lostReplies);
    screen += fmt::format("link: {} cycles lost a reply, {} late or stray datagrams discarded, {} send failures{}\n",
                          ss.lostCycles(), link.discarded, link.sendFailures,
                          failedRecoveries ? fmt::format(", {} channel restarts failed", failedRecoveries) : "");
    if (watchdogBites > 0)
      screen += fmt::format("watchdog: {} bite{} (a remote found this host silent past the 7I77's {} ms and turned "
                            "its outputs off); channels restarted {} time{}\n",
                            watchdogBites, watchdogBites == 1 ? "" : "s", lbpkit::wire::i7i77::kDefaultWatchdogMs,
                            watchdogRestarts, watchdogRestarts == 1 ? "" : "s");
    for (unsigned s = 0; s < ss.slots(); ++s) {
      const auto& id = ss.slotIdentity(s);
      const auto& d = ss.description(s);
      screen += fmt::format("channel {}: {} {} (unit 0x{:08X})  CS: {}\n", id.channel, id.name, id.function(),
                            id.unitNumber, lbpkit::describeCs(ss.cs(s)));
      for (std::size_t i = 0; i < d.processData.size(); ++i) {
        const auto& e = d.processData[i];
        const lbpkit::ElementRef ref{static_cast<std::uint8_t>(s), static_cast<std::uint8_t>(i)};
        std::string v;
        if (e.type == lbpkit::DataType::Bits)
          v = bitsText(ss.raw(ref), e.bits);
        else if (e.numeric())
          v = fmt::format("{:8.3f} {}", ss.value(ref), e.unit);
        else
          v = fmt::format("{}", ss.raw(ref));
        screen += fmt::format("  {:<4} {:<13} {}\n", lbpkit::directionName(e.direction), e.name, v);
      }
    }
    screen += "encoders:";
    for (unsigned n = 0; n < enc.size(); ++n)
      screen += fmt::format("  {}: {} ({:.0f}/s)", n, enc.counts(n), enc.velocity(n));
    screen += "\n";
    if (card.sim) {
      const auto& io = card.sim->card().daughtercard(0).fieldIo;
      screen += fmt::format("LEDs: CR3 {} CR15 {} CR16 {}  field {:.1f} V\n", io.fieldVoltageLed() ? "on" : "off",
                            io.activityLed() ? "on" : "off", io.faultLed() ? "on" : "off", io.fieldVoltage());
    }
    if (watcher) screen += watcher->section();
    fmt::print("{}", screen);
    std::fflush(stdout);
  }
  ss.stopAll();
  return 0;
}

}  // namespace

void addMonitorCommand(CLI::App& app) {
  auto o = std::make_shared<MonitorOptions>();
  auto* cmd = app.add_subcommand("monitor", "Run the 7I77 and show its inputs, outputs, analog values, encoders and "
                                            "faults live (and an `lbpkit sim --machine`'s axes, switches and spindle)");
  o->card.add(*cmd);
  cmd->add_option("--rate", o->servoHz, "Servo cycle rate in Hz")
      ->capture_default_str()
      ->check(inRange(kMinServoHz, kMaxServoHz, " Hz",
                      " (a 7I77 over SSLBP cannot cycle faster than about 10 kHz; LinuxCNC servo threads run at "
                      "1 to 10 kHz)"));
  cmd->add_option("--display", o->displayHz, "Screen updates per second")
      ->capture_default_str()
      ->check(inRange(kMinDisplayHz, kMaxDisplayHz, " per second", ""));
  cmd->add_option("--frames", o->frames, "Stop after this many screens (0: until Ctrl-C)")
      ->check(inRange(0, kMaxFrames, "", " (0: until Ctrl-C)"));
  cmd->add_option("--reply-timeout", o->replyTimeoutMs,
                  "With --addr: how long a cycle waits for each reply, in ms, before it counts the reply lost "
                  "and carries on")
      ->capture_default_str()
      ->check(inRange(kMinReplyTimeoutMs, kMaxReplyTimeoutMs, " ms", ""));
  cmd->add_flag("--demo", o->demo, "Drive a walking output bit and a sine on analog 0 (with --sim also wire the "
                                   "outputs to the inputs and turn an encoder)");
  cmd->add_flag("--plain", o->plain, "Print screens one after another instead of redrawing");
  cmd->add_option("--api", o->api,
                  "[ADDR:]PORT of an `lbpkit sim` control API to show its machine from (default: the card's "
                  "address, port 27182; with --sim none)");
  cmd->add_flag("--no-api", o->noApi, "Do not ask a control API for the machine")->excludes("--api");
  cmd->add_option("--api-token", o->apiToken, "The control API's token, if the sim has one (or LBPKIT_API_TOKEN)")
      ->envname("LBPKIT_API_TOKEN");
  cmd->callback([o] { app::gRun = [o] { return runMonitor(*o); }; });
}
