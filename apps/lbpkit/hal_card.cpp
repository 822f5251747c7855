// SPDX-License-Identifier: MIT
#include "hal_card.hpp"

#include <fmt/format.h>

#include "lbpkit/error.hpp"
#include "lbpkit/sserial.hpp"
#include "sim_card/sim_transport.hpp"

// The layers' namespaces this file names (docs/architecture.md).
namespace hm2 = lbpkit::model::hm2;

namespace lbpkit::app {

std::vector<lbpkit::linuxcnc::Remote> discoverRemotes(lbpkit::Transport& t, const lbpkit::CardInfo& card,
                                                 const lbpkit::linuxcnc::Hm2Config& config) {
  std::vector<lbpkit::linuxcnc::Remote> out;
  const auto* md = card.module(lbpkit::wire::hm2::tag::kSSerial);
  if (!md) return out;
  for (unsigned port = 0; port < md->instances; ++port) {
    if (config.sserialPortGiven && config.sserialPorts.count(port) == 0) continue;
    lbpkit::SmartSerial::Options o;
    o.instance = port;
    o.channelMask = config.channelMask(port);
    for (unsigned ch = 0; ch < 8; ++ch) {
      const char m = config.mode(port, ch);
      o.modes[ch] = static_cast<std::uint8_t>(m == 'x' ? 0 : m - '0');
    }
    lbpkit::SmartSerial ss(t, card, o);
    const auto found = ss.discover(o.channelMask);
    unsigned slot = 0;
    for (const auto& id : found) {
      if (!id.present) continue;
      out.push_back({port, id.channel, id.name, o.modes[id.channel], ss.description(slot++)});
    }
    ss.stopAll();
  }
  return out;
}

VirtualCard virtualCard(const hm2::cards::Card& card, const hm2::cards::Firmware& firmware, unsigned sevenI77s,
                        const lbpkit::linuxcnc::Hm2Config& config) {
  hm2::HostMot2Card::Options options;
  options.card = &card;
  options.pinout = firmware.pinout;
  if (sevenI77s > 1 && firmware.sevenI77s.size() > 1) options.second.emplace();
  lbpkit::SimTransport sim(std::move(options));
  VirtualCard c;
  c.info = lbpkit::readCardInfo(sim);
  c.remotes = discoverRemotes(sim, c.info, config);
  c.halName = std::string(card.halName);
  return c;
}

std::pair<const hm2::cards::Card*, const hm2::cards::Firmware*> catalogueChoice(const std::string& card,
                                                                               const std::string& pinout) {
  const auto* c = card.empty() ? &hm2::cards::defaultCard() : hm2::cards::find(card);
  if (!c) throw lbpkit::Error(fmt::format("--card {}: lbpkit knows {}", card, hm2::cards::names()));
  const auto* f = pinout.empty() ? &c->firmwares.front() : hm2::cards::firmware(*c, pinout);
  if (!f)
    throw lbpkit::Error(
        fmt::format("--pinout {}: the {}'s firmwares are {}", pinout, c->name, hm2::cards::firmwareNames(*c)));
  return {c, f};
}

}  // namespace lbpkit::app
