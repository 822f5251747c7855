// SPDX-License-Identifier: MIT
// The card catalogue. Each card's IDROM as LinuxCNC's
// hostmot2 and mesaflash read it (header, module records, pins), the 7I77
// where its firmware puts it, the 7I92 default unchanged, and the TOML's
// card and pinout keys.
#include <gtest/gtest.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "support/card_host.hpp"
#include "config/card_toml.hpp"
#include "config/toml_reader.hpp"
#include "hostmot2/cards/catalogue.hpp"

// The layers' namespaces this file names (docs/architecture.md).
namespace hm2 = lbpkit::model::hm2;
namespace config = lbpkit::config;

namespace {

using namespace testing_hm2;
namespace cards = hm2::cards;

std::string chars(std::uint32_t w) {
  std::string s;
  for (int i = 0; i < 4; ++i) s.push_back(static_cast<char>(w >> (8 * i)));
  return s;
}

// The IDROM as a driver reads it, through the register file.
struct Idrom {
  struct Record {
    std::uint8_t gtag, version, clock, instances;
    std::uint16_t base;
    std::uint8_t registers, strides;
    std::uint32_t mp;
  };
  std::string boardName;
  std::uint32_t fpgaSize = 0, fpgaPins = 0, ioPorts = 0, ioWidth = 0, portWidth = 0, clockLow = 0, clockHigh = 0;
  std::vector<Record> modules;
  std::vector<std::uint32_t> pins;

  explicit Idrom(hm2::HostMot2Card& card) {
    CardHost h{card};
    const auto base = static_cast<std::uint16_t>(h.read(0x010C));
    auto word = [&](unsigned off) { return h.read(static_cast<std::uint16_t>(base + off)); };
    boardName = chars(word(0x0C)) + chars(word(0x10));
    fpgaSize = word(0x14);
    fpgaPins = word(0x18);
    ioPorts = word(0x1C);
    ioWidth = word(0x20);
    portWidth = word(0x24);
    clockLow = word(0x28);
    clockHigh = word(0x2C);
    for (unsigned i = 0; i < 32; ++i) {
      const auto w0 = word(word(4) + 12 * i), w1 = word(word(4) + 12 * i + 4), w2 = word(word(4) + 12 * i + 8);
      if ((w0 & 0xFF) == 0) break;
      modules.push_back({static_cast<std::uint8_t>(w0), static_cast<std::uint8_t>(w0 >> 8),
                         static_cast<std::uint8_t>(w0 >> 16), static_cast<std::uint8_t>(w0 >> 24),
                         static_cast<std::uint16_t>(w1), static_cast<std::uint8_t>(w1 >> 16),
                         static_cast<std::uint8_t>(w1 >> 24), w2});
    }
    for (unsigned i = 0; i < ioWidth; ++i) pins.push_back(word(word(8) + 4 * i));
  }
  [[nodiscard]] std::vector<std::uint8_t> tags() const {
    std::vector<std::uint8_t> t;
    for (const auto& m : modules) t.push_back(m.gtag);
    return t;
  }
  [[nodiscard]] const Record* find(std::uint8_t gtag) const {
    for (const auto& m : modules)
      if (m.gtag == gtag) return &m;
    return nullptr;
  }
  // Secondary unit, tag and pin code of IO `io`.
  [[nodiscard]] std::uint32_t fn(unsigned io) const { return pins.at(io) & 0x00FFFFFFU; }
};

hm2::HostMot2Card make(const char* name, std::optional<cards::Pinout> pinout = std::nullopt) {
  hm2::HostMot2Card::Options o;
  o.card = cards::find(name);
  EXPECT_NE(o.card, nullptr) << name;
  o.pinout = pinout;
  return hm2::HostMot2Card(o);
}

constexpr std::uint8_t kDpll = 0x1A, kWd = 0x02, kIo = 0x03, kQc = 0x04, kSg = 0x05, kPwm = 0x06, kMqc = 0x0C,
                       kMqs = 0x0D, kSs = 0xC1, kLed = 0x80;

// Module records as LinuxCNC 2.9's hostmot2 accepts them (stepgen.c,
// encoder.c, pwmgen.c: version, registers, instance stride, mask) and as
// the PIN files declare them (IDROMConst.vhd base addresses).
void expectRecordsAsTheDriverWantsThem(const Idrom& r) {
  for (const auto& m : r.modules) {
    SCOPED_TRACE(int(m.gtag));
    switch (m.gtag) {
      case kSg:
        EXPECT_EQ(m.base, 0x2000);
        EXPECT_EQ(m.registers, 10);
        EXPECT_EQ(m.mp, 0x1FFU);
        EXPECT_EQ(m.strides, 0x00);
        EXPECT_EQ(m.clock, 1);
        break;
      case kQc:
        EXPECT_EQ(m.base, 0x3000);
        EXPECT_EQ(m.registers, 5);
        EXPECT_EQ(m.mp, 0x3U);
        EXPECT_TRUE(m.version == 2 || m.version == 3);
        break;
      case kPwm:
        EXPECT_EQ(m.base, 0x4000);
        EXPECT_EQ(m.version, 0);
        EXPECT_EQ(m.registers, 5);
        EXPECT_EQ(m.mp, 0x3U);
        EXPECT_EQ(m.clock, 2);  // PWMGen runs on ClockHigh in the PIN files
        break;
      case kDpll:
        EXPECT_EQ(m.base, 0x7000);
        EXPECT_EQ(m.registers, 7);
        EXPECT_EQ(m.instances, 1);
        break;
      case kMqc: EXPECT_EQ(m.version, 3); break;
      case kSs: EXPECT_EQ(m.strides, 0x10); break;
      default: break;
    }
  }
}

TEST(Cards, TheCatalogueNamesEachCardAsHm2EthAndMesaflashDo) {
  ASSERT_EQ(cards::names(), "7I92, 7I92T, 7I96S, 7I80HD-25");
  EXPECT_EQ(&cards::defaultCard(), cards::find("7I92"));
  EXPECT_EQ(cards::find("7i96s"), cards::find("7I96S"));  // any case
  EXPECT_EQ(cards::find("7I96"), nullptr);
  EXPECT_EQ(cards::find(""), nullptr);
  // hm2_eth (f1270d6ed7): "7I92T" matches its "7I92" entry on four
  // characters, so a 7I92T's pins are hm2_7i92.0.*; "7I96S" gets its own.
  EXPECT_EQ(cards::find("7I92T")->halName, "7i92");
  EXPECT_EQ(cards::find("7I96S")->halName, "7i96s");
  EXPECT_EQ(cards::find("7I80HD-25")->halName, "7i80");
  EXPECT_EQ(cards::firmwareNames(*cards::find("7I92")), "\"7I77x2\", \"7I77+GPIO\", \"7I77+7I76\"");
  for (const auto& c : cards::all()) {
    SCOPED_TRACE(std::string(c.name));
    ASSERT_FALSE(c.firmwares.empty());
    for (const auto& f : c.firmwares) {
      EXPECT_EQ(cards::firmware(c, f.pinout), &f);
      EXPECT_EQ(cards::firmware(c, f.name), &f);
      ASSERT_FALSE(f.sevenI77s.empty());
    }
  }
}

TEST(Cards, TheDefaultIsThe7I92AsItAlwaysWas) {
  hm2::HostMot2Card byDefault;
  auto named = make("7I92", cards::Pinout::SevenI77x2);
  EXPECT_EQ(byDefault.idromWords(), named.idromWords());
  EXPECT_EQ(byDefault.description().name, "7I92");
  EXPECT_EQ(byDefault.pinout(), cards::Pinout::SevenI77x2);
  Idrom r(byDefault);
  EXPECT_EQ(r.boardName, "MESA7I92");
  EXPECT_EQ(r.tags(), (std::vector<std::uint8_t>{kWd, kIo, kMqc, kMqs, kSs, kLed}));
  EXPECT_EQ(byDefault.module(kDpll), nullptr);
}

TEST(Cards, EachCardsIdromHeaderIsItsOwn) {
  struct Expect {
    const char* card;
    const char* boardName;
    std::uint32_t size, pins, ports, width;
  };
  for (const Expect& e : {Expect{"7I92", "MESA7I92", 9, 144, 2, 17}, Expect{"7I92T", "MESA7I92", 20, 256, 2, 17},
                          Expect{"7I96S", "MESA7I96", 20, 256, 3, 17}, Expect{"7I80HD-25", "MESA7I80", 25, 256, 3, 24}}) {
    SCOPED_TRACE(e.card);
    auto card = make(e.card);
    Idrom r(card);
    EXPECT_EQ(r.boardName, e.boardName);
    EXPECT_EQ(r.fpgaSize, e.size);
    EXPECT_EQ(r.fpgaPins, e.pins);
    EXPECT_EQ(r.ioPorts, e.ports);
    EXPECT_EQ(r.portWidth, e.width);
    EXPECT_EQ(r.ioWidth, e.ports * e.width);
    EXPECT_EQ(r.clockLow, 100'000'000U);
    EXPECT_EQ(r.clockHigh, 200'000'000U);
    ASSERT_EQ(r.pins.size(), e.ports * e.width);
    for (auto p : r.pins) EXPECT_EQ(p >> 24, 0x03U);  // primary IOPort
    EXPECT_EQ(r.find(kIo)->instances, e.ports);
    expectRecordsAsTheDriverWantsThem(r);
    // Every module the IDROM lists answers at its base address (the stand-ins
    // too): nothing LinuxCNC touches at load is unmapped.
    CardHost h{card};
    for (const auto& m : r.modules)
      if (m.registers > 0) (void)h.read(m.base);
    EXPECT_EQ(card.accessCounters().unmappedReads, 0U);
  }
}

// PIN_7I77_7I76_34.vhd with Mesa's "d" HM2DPLL first: the 7I92T's default.
TEST(Cards, The7I92TRunsThe7I77And7I76FirmwareWithTheDpll) {
  auto card = make("7I92T");
  EXPECT_EQ(card.firmware().bitfile, "7i92t_7i77_7i76d");
  Idrom r(card);
  EXPECT_EQ(r.tags(), (std::vector<std::uint8_t>{kDpll, kWd, kIo, kMqc, kMqs, kSs, kSg, kLed}));
  EXPECT_EQ(r.find(kMqc)->instances, 8);
  EXPECT_EQ(r.find(kSg)->instances, 5);
  EXPECT_EQ(r.find(kSg)->version, 2);
  EXPECT_EQ(card.part<hm2::Sslbp>().channels(), 5U);
  EXPECT_EQ(card.part<hm2::MuxedEncoder>().counters(), 8U);
  EXPECT_EQ(r.fn(0), 0x00C193U);   // the 7I77 on P2 (IO0): SS2TXEN
  EXPECT_EQ(r.fn(7), 0x000D81U);   // ENCMUX
  EXPECT_EQ(r.fn(17), 0x000582U);  // IO17: StepGen 0 Dir
  EXPECT_EQ(r.fn(18), 0x000581U);  // IO18: StepGen 0 Step
  EXPECT_EQ(r.fn(26), 0x040581U);  // IO26: StepGen 4 Step
  EXPECT_EQ(r.fn(27), 0x00C184U);  // IO27: SS3TX (the 7I76's field I/O)
  EXPECT_EQ(r.fn(30), 0x00C105U);  // IO30: SS4RX
  EXPECT_EQ(r.fn(31), 0x030C03U);  // IO31: muxed counter unit 3 index
  EXPECT_EQ(r.fn(33), 0x030C01U);  // IO33: ... A
  // One 7I77 place: a second 7I77 is refused, naming the way out.
  hm2::HostMot2Card::Options o;
  o.card = cards::find("7I92T");
  o.second = hm2::HostMot2Card::DaughterOptions{};
  EXPECT_THROW(hm2::HostMot2Card{o}, std::invalid_argument);
  o.pinout = cards::Pinout::SevenI77x2;
  hm2::HostMot2Card two(o);
  EXPECT_EQ(two.daughtercards(), 2U);
  EXPECT_EQ(Idrom(two).tags(), (std::vector<std::uint8_t>{kDpll, kWd, kIo, kMqc, kMqs, kSs, kLed}));
}

// The 7I96S: its own step/dir, encoder, RS-422 and PWM on TB1/TB2, the 7I77
// on P1 (IO34..50) on channels 0..2 and muxed counters 0..5.
TEST(Cards, The7I96SHasThe7I77OnP1AndItsOwnStepGensOnTb1Tb2) {
  namespace cmd = hm2::command;
  auto card = make("7I96S");
  Idrom r(card);
  // No QCount beside the MuxedQCount: LinuxCNC's hostmot2 would refuse it.
  // TB3's InM (0x23), SSR (0xC3) and OutM (0x2D): hm2_tb3_modules_test.cpp.
  EXPECT_EQ(r.tags(), (std::vector<std::uint8_t>{kDpll, kWd, kIo, kSg, kMqc, kMqs, kSs, kPwm, 0x23, 0xC3, 0x2D, kLed}));
  EXPECT_EQ(r.find(kSg)->instances, 5);
  EXPECT_EQ(r.find(kMqc)->instances, 8);
  EXPECT_EQ(r.find(kPwm)->instances, 1);
  EXPECT_EQ(r.fn(17), 0x000581U);  // TB1: StepGen 0 Step
  EXPECT_EQ(r.fn(18), 0x000582U);  // StepGen 0 Dir
  EXPECT_EQ(r.fn(25), 0x040581U);  // StepGen 4 Step
  EXPECT_EQ(r.fn(27), 0x030C01U);  // TB2: encoder A (muxed counter unit 3)
  EXPECT_EQ(r.fn(29), 0x030C03U);  // encoder index
  EXPECT_EQ(r.fn(30), 0x00C104U);  // RS-422 RX: channel 3
  EXPECT_EQ(r.fn(32), 0x00C194U);  // its TX enable
  EXPECT_EQ(r.fn(33), 0x000681U);  // spindle PWM
  EXPECT_EQ(r.fn(34), 0x00C193U);  // P1: the 7I77's SS2TXEN
  EXPECT_EQ(r.fn(39), 0x00C181U);  // SS0TX
  EXPECT_EQ(r.fn(41), 0x000D81U);  // ENCMUX
  EXPECT_EQ(r.fn(50), 0x020C03U);  // QCMUXI45
  // The 7I77 answers on channels 0 and 1; channels 2 (TB6) and 3 (TB2) have nobody.
  CardHost h{card};
  EXPECT_EQ(card.part<hm2::Sslbp>().channels(), 4U);
  h.command(cmd::kStop);
  for (unsigned ch = 0; ch < 4; ++ch) h.write(CardHost::cs(ch), 0);
  EXPECT_EQ(h.command(cmd::kStart | 0x0F), 0x0C);
  EXPECT_TRUE(card.part<hm2::Sslbp>().channelRunning(0));
  EXPECT_TRUE(card.part<hm2::Sslbp>().channelRunning(1));
  EXPECT_EQ(card.daughtercard(0).fieldIo.unitNumber() >> 24, 0x12U);
}

TEST(Cards, The7I80HDHasThe7I77OnIo0To16OfThreeTwentyFourPinPorts) {
  auto card = make("7I80HD-25");
  Idrom r(card);
  EXPECT_EQ(r.tags(), (std::vector<std::uint8_t>{kWd, kIo, kMqc, kMqs, kSs, kLed}));
  EXPECT_EQ(card.part<hm2::Sslbp>().channels(), 3U);
  EXPECT_EQ(r.fn(0), 0x00C193U);
  EXPECT_EQ(r.fn(16), 0x020C03U);
  for (unsigned io = 17; io < 72; ++io) EXPECT_EQ(r.fn(io), 0U) << io;
  // The IOPort is 24 bits wide: an output on IO23 (the first port's last pin).
  CardHost h{card};
  h.write(hm2::IoPort::kDdr, 1U << 23);
  h.write(hm2::IoPort::kData, 0);
  EXPECT_FALSE(card.part<hm2::IoPort>().pin(0, 23));
  EXPECT_EQ(h.read(hm2::IoPort::kDdr), 1U << 23);
}

// The StepGens, PWMGen and DPLL of a firmware are the card's (the
// models in src/models/hostmot2), the StepGens timed by its DPLL; a firmware without them has none.
TEST(Cards, TheFirmwaresStepGensPwmGenAndDpllAreTheCards) {
  hm2::HostMot2Card plain;
  EXPECT_EQ(plain.module<hm2::StepGen>(), nullptr);
  EXPECT_EQ(plain.module<hm2::PwmGen>(), nullptr);
  EXPECT_EQ(plain.module<hm2::Dpll>(), nullptr);
  auto card = make("7I96S");
  ASSERT_NE(card.module<hm2::StepGen>(), nullptr);
  ASSERT_NE(card.module<hm2::PwmGen>(), nullptr);
  ASSERT_NE(card.module<hm2::Dpll>(), nullptr);
  EXPECT_EQ(card.module(0x05), card.module<hm2::StepGen>());
  EXPECT_EQ(card.module(0x06), card.module<hm2::PwmGen>());
  EXPECT_EQ(card.module(0x1A), card.module<hm2::Dpll>());
  EXPECT_EQ(card.module<hm2::StepGen>()->descriptor().instances, 5);
  // Each record in the IDROM is the module's own descriptor.
  Idrom r(card);
  std::size_t i = 0;
  for (const hm2::Module* m : card.modules()) {
    const auto d = m->descriptor();
    ASSERT_LT(i, r.modules.size());
    EXPECT_EQ(r.modules[i].gtag, d.gtag);
    EXPECT_EQ(r.modules[i].base, d.baseAddress);
    EXPECT_EQ(r.modules[i].instances, d.instances);
    ++i;
  }
  EXPECT_EQ(i, r.modules.size());
  auto t = make("7I92T");
  ASSERT_NE(t.module<hm2::StepGen>(), nullptr);
  EXPECT_EQ(t.module<hm2::PwmGen>(), nullptr);
  ASSERT_NE(t.module<hm2::Dpll>(), nullptr);
}

std::string writeToml(const std::string& text) {
  static int n = 0;
  const auto path = (std::filesystem::temp_directory_path() /
                     ("lbpkit-cards-" + std::to_string(::getpid()) + "-" + std::to_string(n++) + ".toml"))
                        .string();
  std::ofstream(path) << text;
  return path;
}

std::string loadError(const std::string& text, hm2::HostMot2Card::Options& o) {
  const auto path = writeToml(text);
  std::string what;
  try {
    config::loadConfig(path, o);
  } catch (const std::exception& e) {
    what = e.what();
  }
  std::filesystem::remove(path);
  return what;
}

TEST(Cards, TheTomlNamesTheCardAndOneOfItsFirmwares) {
  {
    hm2::HostMot2Card::Options o;
    EXPECT_EQ(loadError("[card]\nname = \"7i96s\"\n", o), "");
    ASSERT_EQ(o.card, cards::find("7I96S"));
    EXPECT_FALSE(o.pinout.has_value());  // the card's own
    hm2::HostMot2Card card(o);
    EXPECT_EQ(card.board().boardName, "MESA7I96");
  }
  {
    hm2::HostMot2Card::Options o;
    EXPECT_EQ(loadError("[card]\nname = \"7I92\"\npinout = \"7I77+7I76\"\n", o), "");
    EXPECT_EQ(o.pinout, cards::Pinout::SevenI77SevenI76);
  }
  hm2::HostMot2Card::Options o;
  auto e = loadError("[card]\nname = \"7I98\"\n", o);
  EXPECT_NE(e.find("card.name: \"7I98\" is not one of \"7I92\", \"7I92T\", \"7I96S\", \"7I80HD-25\""), std::string::npos) << e;
  e = loadError("[card]\nname = \"7I96S\"\npinout = \"7I77x2\"\n", o);
  EXPECT_NE(e.find(":3:10: card.pinout: \"7I77x2\" is not one of \"7I96S+7I77\""), std::string::npos) << e;
  // --card said one thing, the file another.
  hm2::HostMot2Card::Options fromCli;
  fromCli.card = cards::find("7I92T");
  e = loadError("[card]\nname = \"7I96S\"\n", fromCli);
  EXPECT_NE(e.find("card.name: \"7I96S\", but lbpkit sim --card says the 7I92T"), std::string::npos) << e;
  // With --card and no name in the file, the pinout is the card's.
  fromCli = {};
  fromCli.card = cards::find("7I92T");
  EXPECT_EQ(loadError("[card]\npinout = \"7I77x2\"\n[[daughtercard]]\n[[daughtercard]]\n", fromCli), "");
  EXPECT_EQ(fromCli.pinout, cards::Pinout::SevenI77x2);
  EXPECT_TRUE(fromCli.second.has_value());
  // A second 7I77 where the firmware has one place.
  o = {};
  e = loadError("[card]\nname = \"7I96S\"\n[[daughtercard]]\n[[daughtercard]]\ntype = \"7I77D\"\n", o);
  EXPECT_NE(e.find("daughtercard[1].type: the 7I96S+7I77 pinout of the 7I96S has one 7I77 connector"),
            std::string::npos)
      << e;
}

}  // namespace
