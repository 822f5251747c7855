// SPDX-License-Identifier: MIT
#include "config/card_toml.hpp"

#include <fmt/core.h>

#include <cstdint>
#include <optional>
#include <string>
#include <utility>

#include "config/toml_reader.hpp"
#include "lbpkit/wire/seven_i77.hpp"

namespace lbpkit::config {

void loadConfig(const std::string& path, model::hm2::HostMot2Card::Options& card) {
  const toml::table t = parseFile(path, "a TOML configuration file");
  const ConfigReader r(path);
  r.onlyKeys(t, "", {"card", "daughtercard", "fault"});  // fault: config/fault_script
  if (const toml::table* cardTable = r.table(t, "", "card")) {
    r.onlyKeys(*cardTable, "card.", {"name", "pinout"});
    // The card (hostmot2/cards/catalogue.hpp; `lbpkit sim --card` may have
    // named it already) and the FPGA's firmware on it: for the 7I92 Mesa's
    // two-7I77 one (PIN_7I77x2_34.vhd) whatever is plugged in, lbpkit's one
    // 7I77 with GPIO on the second connector, or Mesa's 7I77 + 7I76.
    auto textOf = [&](const char* key) -> std::optional<std::string> {
      const toml::node* n = cardTable->get(key);
      if (n == nullptr) return std::nullopt;
      const auto v = n->value_exact<std::string>();
      if (!v) r.fail(n, fmt::format("card.{}", key), "expected a string");
      return *v;
    };
    if (const auto name = textOf("name")) {
      const model::hm2::cards::Card* c = model::hm2::cards::find(*name);
      std::string list;
      for (const auto& k : model::hm2::cards::all())
        list += (list.empty() ? "\"" : ", \"") + std::string(k.name) + "\"";
      if (c == nullptr) r.fail(cardTable->get("name"), "card.name", fmt::format("\"{}\" is not one of {}", *name, list));
      if (card.card != nullptr && card.card != c)
        r.fail(cardTable->get("name"), "card.name",
               fmt::format("\"{}\", but lbpkit sim --card says the {}", *name, card.card->name));
      card.card = c;
    }
    const auto& chosen = card.card != nullptr ? *card.card : model::hm2::cards::defaultCard();
    if (const auto pinout = textOf("pinout")) {
      const auto* f = model::hm2::cards::firmware(chosen, *pinout);
      if (f == nullptr)
        r.fail(cardTable->get("pinout"), "card.pinout",
               fmt::format("\"{}\" is not one of {}{}", *pinout, model::hm2::cards::firmwareNames(chosen),
                           chosen.firmwares.size() > 1 ? fmt::format(" (the {}'s firmwares)", chosen.name) : ""));
      card.pinout = f->pinout;
    }
  }
  const auto& chosen = card.card != nullptr ? *card.card : model::hm2::cards::defaultCard();
  const auto& firmware = *(card.pinout ? model::hm2::cards::firmware(chosen, *card.pinout) : &chosen.firmwares.front());
  const toml::array* boards = r.tables(t, "", "daughtercard");
  if (boards == nullptr) return;
  // One table per connector a firmware gives a 7I77 (two at most: a 7I92's
  // with the 7I77x2 firmware); the second may say "none".
  if (boards->size() > 2)
    r.fail(t.get("daughtercard"), "daughtercard",
           fmt::format("a {} takes at most two 7I77s (the {} pinout: {}), not {}", chosen.name, firmware.name,
                       firmware.sevenI77s.size(), boards->size()));
  for (std::size_t i = 0; i < boards->size(); ++i) {
    const toml::table& b = r.element(*boards, "daughtercard", i);
    const auto prefix = fmt::format("daughtercard[{}].", i);
    r.onlyKeys(b, prefix,
               {"type", "field_voltage", "w1", "vin", "w12_setup", "w4_setup", "field_io_unit", "analog_unit"});
    const auto type = r.text(b, prefix, "type", "7I77", {"7I77", "7I77D", "none"});
    if (i == 1 && type != "none" && firmware.sevenI77s.size() < 2)
      r.fail(b.get("type") != nullptr ? b.get("type") : &b, prefix + "type",
             firmware.pinout == model::hm2::cards::Pinout::SevenI77Gpio
                 ? std::string("the 7I77+GPIO pinout has GPIO on the second connector: use pinout = \"7I77x2\" for a "
                               "second 7I77")
                 : fmt::format("the {} pinout of the {} has one 7I77 connector{}", firmware.name, chosen.name,
                               model::hm2::cards::firmware(chosen, model::hm2::cards::Pinout::SevenI77x2) != nullptr
                                   ? ": use pinout = \"7I77x2\" for a second 7I77"
                                   : ""));
    if (type == "none") {
      if (i == 0) r.fail(b.get("type"), prefix + "type", "the first connector must carry a 7I77");
      continue;
    }
    model::hm2::HostMot2Card::DaughterOptions d;
    if (i == 1 && !card.first.fieldIo.nvFile.empty()) {
      d.fieldIo.nvFile = card.first.fieldIo.nvFile.string() + ".2";
      d.analog.nvFile = card.first.analog.nvFile.string() + ".2";
    }
    d.fieldIo.outputs = type == "7I77D" ? model::remote::OutputType::Sinking : model::remote::OutputType::Sourcing;
    // Rated 5..28 V field power and 10..32 V VIN (manual: SPECIFICATIONS);
    // lower values model a failing supply, above 36 V nothing survives.
    d.fieldIo.fieldVoltage = r.number(b, prefix, "field_voltage", 24.0, 0.0, 36.0, "V");
    d.fieldIo.vinFromField = r.text(b, prefix, "w1", "field", {"field", "separate"}) == "field";
    d.fieldIo.vin = r.number(b, prefix, "vin", 24.0, 0.0, 36.0, "V");
    d.fieldIo.setupMode = r.boolean(b, prefix, "w12_setup", false);
    d.analog.setupMode = r.boolean(b, prefix, "w4_setup", false);
    // Each board has its own serial number (the low 24 bits of both units);
    // the top byte says which processor it is.
    namespace unit = lbpkit::wire::i7i77::unit_type;
    const std::int64_t serial = 0x000AEE + static_cast<std::int64_t>(i);
    const auto unitRange = [](std::uint8_t top) {
      return std::pair<std::int64_t, std::int64_t>{std::int64_t{top} << unit::kShift,
                                                   (std::int64_t{top} << unit::kShift) | 0xFFFFFF};
    };
    const auto [ioMin, ioMax] = unitRange(unit::kFieldIo);
    const auto [anMin, anMax] = unitRange(unit::kAnalog);
    constexpr auto hex = ConfigReader::Radix::Hex;
    d.fieldIo.unitNumber =
        static_cast<std::uint32_t>(r.integer(b, prefix, "field_io_unit", ioMin + serial, ioMin, ioMax, hex));
    d.analog.unitNumber =
        static_cast<std::uint32_t>(r.integer(b, prefix, "analog_unit", anMin + serial, anMin, anMax, hex));
    if (i == 0) {
      d.fieldIo.nvFile = card.first.fieldIo.nvFile;
      d.analog.nvFile = card.first.analog.nvFile;
      card.first = d;
    } else {
      card.second = d;
    }
  }
}

}  // namespace lbpkit::config
