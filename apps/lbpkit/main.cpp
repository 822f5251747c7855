// SPDX-License-Identifier: MIT
// lbpkit: tools for the Mesa 7I77 system, real or virtual.
#include <fmt/core.h>

#include <functional>

#include "common.hpp"
#include "lbpkit/error.hpp"

// The layers' namespaces this file names (docs/architecture.md).
namespace app = lbpkit::app;

namespace lbpkit::app {
std::function<int()> gRun;
}

void addDecodeCommand(CLI::App& app);  // cmd_decode.cpp

int main(int argc, char** argv) {
  CLI::App app{"lbpkit: the Mesa 7I77 servo/IO system, real or virtual.\n"
               "Every card tool works on the in-process virtual card (--sim, the default) or a card on the network "
               "(--addr IP)."};
  app.require_subcommand(1);
  // LBPKIT_VERSION is the project's VERSION (top-level CMakeLists.txt), set on
  // this file by cmake/LbpkitPackage.cmake.
  app.set_version_flag("--version", "lbpkit " LBPKIT_VERSION, "Print the version and exit");
  addInfoCommand(app);
  addDiscoverCommand(app);
  addParameterCommands(app);
  addMonitorCommand(app);
  addSimCommand(app);
  addRemoteCommand(app);
  addFaultCommand(app);
  addPinsCommand(app);
  addCheckConfigCommand(app);
  addBenchCommand(app);
  addDecodeCommand(app);
  addLinuxCncCommand(app);
  addMachineCommand(app);
  addRehearseCommand(app);
  CLI11_PARSE(app, argc, argv);
  try {
    return app::gRun ? app::gRun() : 0;
  } catch (const lbpkit::Error& e) {
    fmt::print(stderr, "lbpkit: {}\n", e.what());
    return 1;
  } catch (const std::exception& e) {
    fmt::print(stderr, "lbpkit: {}\n", e.what());
    return 1;
  }
}
