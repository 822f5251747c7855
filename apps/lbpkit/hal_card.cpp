#include "hal_card.hpp"

#include "lbpkit/sserial.hpp"
#include "sim_card/sim_transport.hpp"

namespace app {

std::vector<lbpkit::hal::Remote> discoverRemotes(lbpkit::Transport& t, const lbpkit::CardInfo& card,
                                                 const lbpkit::hal::Hm2Config& config) {
  std::vector<lbpkit::hal::Remote> out;
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

VirtualCard virtualCard(unsigned sevenI77s, const lbpkit::hal::Hm2Config& config) {
  hm2::HostMot2Card::Options options;
  if (sevenI77s > 1) options.second.emplace();
  lbpkit::SimTransport sim(std::move(options));
  VirtualCard c;
  c.info = lbpkit::readCardInfo(sim);
  c.remotes = discoverRemotes(sim, c.info, config);
  return c;
}

}  // namespace app
