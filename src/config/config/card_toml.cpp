#include "config/card_toml.hpp"

#include <fmt/core.h>

#include <cstdint>
#include <utility>

#include "config/toml_reader.hpp"
#include "lbpkit/wire/seven_i77.hpp"

namespace config {

void loadConfig(const std::string& path, hm2::HostMot2Card::Options& card) {
  const toml::table t = parseFile(path, "a TOML configuration file");
  const ConfigReader r(path);
  r.onlyKeys(t, "", {"card", "daughtercard", "fault"});  // fault: config/fault_script
  if (const toml::table* cardTable = r.table(t, "", "card")) {
    r.onlyKeys(*cardTable, "card.", {"name", "pinout"});
    (void)r.text(*cardTable, "card.", "name", "7I92", {"7I92"});  // the only card modelled
    // The FPGA's firmware: Mesa's two-7I77 one (PIN_7I77x2_34.vhd) whatever
    // is plugged in, or lbpkit's one 7I77 with GPIO on the second connector.
    card.pinout = r.text(*cardTable, "card.", "pinout", "7I77x2", {"7I77x2", "7I77+GPIO"}) == "7I77x2"
                      ? hm2::HostMot2Card::Pinout::SevenI77x2
                      : hm2::HostMot2Card::Pinout::SevenI77Gpio;
  }
  const toml::array* boards = r.tables(t, "", "daughtercard");
  if (boards == nullptr) return;
  if (boards->size() > 2)
    r.fail(t.get("daughtercard"), "daughtercard", fmt::format("a 7I92 has two connectors, not {}", boards->size()));
  for (std::size_t i = 0; i < boards->size(); ++i) {
    const toml::table& b = r.element(*boards, "daughtercard", i);
    const auto prefix = fmt::format("daughtercard[{}].", i);
    r.onlyKeys(b, prefix,
               {"type", "field_voltage", "w1", "vin", "w12_setup", "w4_setup", "field_io_unit", "analog_unit"});
    const auto type = r.text(b, prefix, "type", "7I77", {"7I77", "7I77D", "none"});
    if (i == 1 && type != "none" && card.pinout != hm2::HostMot2Card::Pinout::SevenI77x2)
      r.fail(b.get("type") != nullptr ? b.get("type") : &b, prefix + "type",
             "the 7I77+GPIO pinout has GPIO on the second connector: use pinout = \"7I77x2\" for a second 7I77");
    if (type == "none") {
      if (i == 0) r.fail(b.get("type"), prefix + "type", "the first connector must carry a 7I77");
      continue;
    }
    hm2::HostMot2Card::DaughterOptions d;
    if (i == 1 && !card.first.fieldIo.nvFile.empty()) {
      d.fieldIo.nvFile = card.first.fieldIo.nvFile.string() + ".2";
      d.analog.nvFile = card.first.analog.nvFile.string() + ".2";
    }
    d.fieldIo.outputs = type == "7I77D" ? remote::OutputType::Sinking : remote::OutputType::Sourcing;
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

}  // namespace config
