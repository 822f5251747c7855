// SPDX-License-Identifier: MIT
// The HostMot2 module map (lbpkit/wire/hostmot2_modules.hpp) against what
// uses it: every card's modules answer with the map's descriptor and
// power-up values, decode what the map says and refuse writes to its
// read-only registers; docs/hostmot2-modules.md's module map is the map.
#include <gtest/gtest.h>

#include <fmt/format.h>

#include <fstream>
#include <regex>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "hostmot2/card.hpp"
#include "hostmot2/cards/catalogue.hpp"
#include "lbpkit/wire/hostmot2_modules.hpp"

// The layers' namespaces this file names (docs/architecture.md).
namespace hm2 = lbpkit::model::hm2;

namespace {

namespace map = lbpkit::wire::hm2;
namespace cards = hm2::cards;

std::string scopeName(map::Scope s) {
  switch (s) {
    case map::Scope::Single: return "single";
    case map::Scope::PerInstance: return "per instance";
    case map::Scope::PerChannel: return "per channel";
  }
  return "?";
}

std::string accessName(map::Access a) {
  switch (a) {
    case map::Access::ReadWrite: return "read/write";
    case map::Access::ReadOnly: return "read only";
    case map::Access::WriteOnly: return "write only";
  }
  return "?";
}

// The doc's two tables as the map gives them.
std::vector<std::string> mapTables() {
  std::vector<std::string> lines = {
      "| module | tag | LinuxCNC | clock | base | version | IDROM registers | multiple-register mask |",
      "|---|---|---|---|---|---|---|---|"};
  for (const map::ModuleKind* k : map::kModuleKinds)
    lines.push_back(fmt::format("| {} | 0x{:02X} | {} | {} | {} | {} | {} | 0x{:X} |", k->name, k->tag, k->halWord,
                                k->clock == map::kClockLow ? "ClockLow" : "ClockHigh",
                                k->base == 0 ? std::string("none") : fmt::format("0x{:04X}", k->base), k->version,
                                k->idromRegisters, k->multipleRegisters()));
  lines.push_back("| module | register | address | repeated | access | power-up |");
  lines.push_back("|---|---|---|---|---|---|");
  for (const map::ModuleKind* k : map::kModuleKinds)
    for (const map::Register& r : k->registers)
      lines.push_back(fmt::format(
          "| {} | {} | 0x{:04X} | {} | {} | {} |", k->name, r.name, k->address(r.index),
          scopeName(r.scope) + (r.presence == map::Presence::WithDpll ? ", with an HM2DPLL" : ""),
          accessName(r.access), r.powerUp ? fmt::format("0x{:X}", *r.powerUp) : std::string("see below")));
  return lines;
}

std::string readDoc() {
  std::ifstream in(LBPKIT_DOCS_DIR "/hostmot2-modules.md");
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

TEST(ModuleMap, TheDocsTablesAreTheMap) {
  const std::string doc = readDoc();
  ASSERT_FALSE(doc.empty()) << "docs/hostmot2-modules.md not found";
  const auto start = doc.find("\n## The module map\n");
  ASSERT_NE(start, std::string::npos) << "docs/hostmot2-modules.md has no \"## The module map\" section";
  const auto end = doc.find("\n## ", start + 1);
  std::istringstream section(doc.substr(start, end - start));
  std::vector<std::string> tables;
  for (std::string line; std::getline(section, line);)
    if (line.starts_with("|")) tables.push_back(line);
  const auto expected = mapTables();
  std::string text;
  for (const auto& l : expected) text += l + "\n";
  EXPECT_EQ(tables, expected) << "docs/hostmot2-modules.md's module map differs from "
                                 "lbpkit/wire/hostmot2_modules.hpp; the tables it should have:\n"
                              << text;
}

TEST(ModuleMap, EveryAddressTheDocsTablesNameIsInTheMap) {
  // The per-module sections' register tables ("| 0x2000 | rate | ...").
  std::set<unsigned> addresses;
  for (const map::ModuleKind* k : map::kModuleKinds)
    for (const map::Register& r : k->registers) addresses.insert(k->address(r.index));
  const std::string doc = readDoc();
  const std::regex row(R"(\n\| 0x([0-9A-F]{4}) \| ([^|]+) \|)");
  unsigned rows = 0;
  for (auto it = std::sregex_iterator(doc.begin(), doc.end(), row); it != std::sregex_iterator(); ++it, ++rows) {
    const unsigned address = static_cast<unsigned>(std::stoul((*it)[1].str(), nullptr, 16));
    EXPECT_TRUE(addresses.contains(address))
        << "docs/hostmot2-modules.md names a register at 0x" << (*it)[1] << " (" << (*it)[2]
        << ") that the module map does not have";
  }
  EXPECT_GT(rows, 20U);
}

TEST(ModuleMap, TagsAndNamesAreOneEach) {
  std::set<std::uint8_t> tags;
  for (const map::ModuleKind* k : map::kModuleKinds) {
    EXPECT_TRUE(tags.insert(k->tag).second) << k->name;
    EXPECT_EQ(map::moduleKind(k->tag), k);
    EXPECT_EQ(map::moduleName(k->tag), k->name);
    unsigned index = 0;
    for (const map::Register& r : k->registers) EXPECT_EQ(r.index, index++) << k->name << " " << r.name;
  }
  EXPECT_EQ(map::kModuleKinds.size(), 13U);
  EXPECT_EQ(map::moduleKind(0x99), nullptr);
}

// Every card and firmware here: each module's IDROM record is its kind's,
// every register the map has answers (instance 0) with its power-up value
// where the map gives one, and a write to a read-only register is refused.
TEST(ModuleMap, EveryFirmwaresModulesAnswerAsTheMapSays) {
  unsigned checked = 0;
  for (const auto& card : cards::all()) {
    for (const auto& fw : card.firmwares) {
      hm2::HostMot2Card::Options o;
      o.card = &card;
      o.pinout = fw.pinout;
      hm2::HostMot2Card c(o);
      const bool dpll = c.module(map::tag::kDpll) != nullptr;
      for (hm2::Module* m : c.modules()) {
        const map::ModuleKind& k = m->kind();
        const auto d = m->descriptor();
        const std::string where = fmt::format("{} {}: {}", card.name, fw.name, k.name);
        EXPECT_EQ(d.gtag, k.tag) << where;
        EXPECT_EQ(d.clockTag, k.clock) << where;
        EXPECT_EQ(d.registers, k.idromRegisters) << where;
        EXPECT_EQ(d.strides, k.strides) << where;
        EXPECT_EQ(d.multipleRegisters, k.multipleRegisters()) << where;
        for (const map::Register& r : k.registers) {
          const auto address = static_cast<std::uint16_t>(d.baseAddress + r.index * map::kRegisterStride);
          const bool present = r.presence == map::Presence::Always || dpll;
          EXPECT_EQ(m->decodes(address), present) << where << " " << r.name;
          if (!present) continue;
          if (r.powerUp && r.access != map::Access::WriteOnly) {
            EXPECT_EQ(c.read32(address, c.now()), *r.powerUp) << where << " " << r.name;
            ++checked;
          }
        }
      }
    }
  }
  EXPECT_GT(checked, 100U);
}

TEST(ModuleMap, TheBaseRefusesWritesTheMapForbids) {
  hm2::HostMot2Card card;
  auto& encoders = card.part<hm2::MuxedEncoder>();
  EXPECT_EQ(encoders.write(hm2::MuxedEncoder::kTimestamp, 1, card.now()), hm2::WriteResult::ReadOnly);
  // Write-only: the LEDs read 0 whatever was written.
  card.write32(hm2::Led::kLeds, 0xF0000000U, card.now());
  EXPECT_EQ(card.read32(hm2::Led::kLeds, card.now()), 0U);
  EXPECT_EQ(card.part<hm2::Led>().leds(), 0xFU);
  // Nothing there: a block the muxed counters do not have past the rate.
  EXPECT_FALSE(encoders.decodes(static_cast<std::uint16_t>(hm2::MuxedEncoder::kRate + 4)));
  EXPECT_EQ(encoders.write(static_cast<std::uint16_t>(hm2::MuxedEncoder::kRate + 4), 1, card.now()),
            hm2::WriteResult::Unmapped);
}

}  // namespace
