// SPDX-License-Identifier: MIT
// Drive a Mesa 7I92 with a 7I77 (or `lbpkit sim`) over Ethernet with the
// installed lbpkit library: open the card by IP address, read what it is,
// discover the smart-serial remotes, start them, and run the real-time
// cycle. Each cycle is one UDP exchange: this cycle's outputs and the DOIT
// out, the remotes' inputs back.
//
//   cycle ADDRESS[:PORT] [CYCLES] [RATE_HZ]      e.g.  cycle 192.168.1.121 2000 1000
//
// Field output 0 blinks (50 cycles on, 50 off); every 50 cycles a line shows
// it and the 32 field inputs (`lbpkit sim --demo` wires outputs 0..15 back
// to inputs 0..15, so input 0 follows output 0).
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <exception>
#include <string>
#include <thread>

#include "lbpkit/error.hpp"
#include "lbpkit/hostmot2.hpp"
#include "lbpkit/lbp16_transport.hpp"
#include "lbpkit/sserial.hpp"

int main(int argc, char** argv) {
  if (argc < 2) {
    std::fprintf(stderr, "usage: %s ADDRESS[:PORT] [CYCLES] [RATE_HZ]\n", argv[0]);
    return 2;
  }
  try {
    std::string address = argv[1];
    std::uint16_t port = lbpkit::Lbp16Transport::kPort;  // 27181, as on a real card
    if (const auto colon = address.find(':'); colon != std::string::npos) {
      port = static_cast<std::uint16_t>(std::stoul(address.substr(colon + 1)));
      address.resize(colon);
    }
    const unsigned long cycles = argc > 2 ? std::stoul(argv[2]) : 1000;
    const double rateHz = argc > 3 ? std::stod(argv[3]) : 1000.0;

    // The card's registers, reached by LBP16 over UDP. Set-up calls throw
    // lbpkit::Error when the card does not answer.
    lbpkit::Lbp16Transport card(address, port);
    const lbpkit::CardInfo info = lbpkit::readCardInfo(card);  // IDROM, checked as LinuxCNC does
    std::printf("%s: %s, %zu modules, %u smart-serial channels\n", card.describe().c_str(),
                info.boardName.c_str(), info.modules.size(), info.sserialChannels());

    // Smart serial: STOP ALL, START in setup mode and read each remote's
    // process data tables, then START the remotes found in normal mode.
    lbpkit::SmartSerial sserial(card, info);
    for (const lbpkit::ChannelIdentity& remote : sserial.discover())
      if (remote.present)
        std::printf("channel %u: %s %s (unit 0x%08X)\n", remote.channel, remote.name.c_str(),
                    remote.function().c_str(), remote.unitNumber);
    sserial.startNormal();

    // Process data is found by name once; the cycle itself does no lookups
    // and no allocation. On a 7I77, channel 0 is the field I/O processor.
    const lbpkit::ElementRef inputs = sserial.find(0, "Input");
    const lbpkit::ElementRef outputs = sserial.find(0, "Output");
    if (!inputs.valid() || !outputs.valid()) throw lbpkit::Error("no 7I77 field I/O on channel 0");

    const auto period = std::chrono::duration_cast<std::chrono::steady_clock::duration>(
        std::chrono::duration<double>(1.0 / rateHz));
    auto next = std::chrono::steady_clock::now();
    unsigned long failed = 0;
    for (unsigned long n = 0; n < cycles; ++n) {
      const bool on = (n / 50) % 2 == 1;
      sserial.setBit(outputs, 0, on);
      // Write the outputs and DOIT, wait for the remotes, read CS and inputs.
      // `ok` is false when a remote or the network did not answer in time;
      // the inputs then keep their last good values, and the next cycle
      // simply tries again.
      const lbpkit::CycleStatus status = sserial.cycle();
      if (!status.ok)
        ++failed;
      else if (n % 50 == 25)
        std::printf("cycle %lu: output 0 %s, inputs 0x%08llx\n", n, on ? "on" : "off",
                    static_cast<unsigned long long>(sserial.raw(inputs)));
      next += period;  // a steady rate, whatever each cycle took
      std::this_thread::sleep_until(next);
    }
    // Stop the channels: the remotes' watchdogs then turn their outputs off.
    sserial.stopAll();
    std::printf("%lu cycles at %.0f Hz, %lu failed\n", cycles, rateHz, failed);
    return failed < cycles ? 0 : 1;
  } catch (const std::exception& e) {  // lbpkit::Error, or a bad number in the arguments
    std::fprintf(stderr, "cycle: %s\n", e.what());
    return 1;
  }
}
