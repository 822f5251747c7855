// SPDX-License-Identifier: MIT
// lbpkit info: the card, its IDROM modules, and pin functions by connector.
#include <fmt/core.h>

#include <functional>

#include "common.hpp"
#include "lbpkit/wire/hostmot2.hpp"

// The layers' namespaces this file names (docs/architecture.md).
namespace app = lbpkit::app;

namespace lbpkit::app {
extern std::function<int()> gRun;
}

namespace {

int runInfo(const app::CardOptions& o) {
  auto card = app::openCard(o);
  const auto& i = card.info;
  fmt::print("Card: {} ({})\n", i.boardName, card.transport->describe());
  fmt::print("  configuration {}, IDROM type {}, clocks {:.1f} / {:.1f} MHz\n", i.configName, i.idromType,
             i.clockLow / 1e6, i.clockHigh / 1e6);
  fmt::print("  {} I/O ports of {} pins ({} pins), FPGA {} kgates, {} pins\n", i.ioPorts, i.portWidth, i.ioWidth,
             i.fpgaSize, i.fpgaPins);
  fmt::print("Modules:\n");
  for (const auto& m : i.modules)
    fmt::print("  {:<15} x{:<2} version {}  base 0x{:04X}  {} registers  strides 0x{:X}/0x{:X}  {} clock\n", m.name,
               m.instances, m.version, m.baseAddress, m.registers, m.registerStride, m.instanceStride,
               m.clockTag == lbpkit::wire::hm2::kClockLow ? "low" : "high");
  fmt::print("Pins:\n");
  for (const auto& p : i.pins) {
    if (p.bit == 0) fmt::print("  connector {} (IO{}..IO{}):\n", p.connector, p.io, p.io + i.portWidth - 1);
    fmt::print("    IO{:<3} {}\n", p.io, p.function());
  }
  fmt::print("Smart-serial channels: {}\n", i.sserialChannels());
  return 0;
}

}  // namespace

void addInfoCommand(CLI::App& app) {
  auto o = std::make_shared<app::CardOptions>();
  auto* cmd = app.add_subcommand("info", "Show the card: IDROM, modules, and the function of every pin");
  o->add(*cmd);
  cmd->callback([o] { app::gRun = [o] { return runInfo(*o); }; });
}
