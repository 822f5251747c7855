// SPDX-License-Identifier: MIT
// PNCconf's corpus (tests/pncconf/configs/, written by Debian's PNCconf
// from tests/pncconf/generate.py's answers): each configuration through
// exactly what a user runs, with the user's defaults. `lbpkit check-config
// INI` finds no error, and `lbpkit machine --from-config INI -o M.toml`
// writes a machine that loads as `lbpkit sim --machine M.toml` loads it;
// or, for a configuration listed in tests/pncconf/README.md ("What cannot
// be derived yet"), fails with exactly the message listed there.
#include <gtest/gtest.h>

#include <algorithm>
#include <cctype>
#include <exception>
#include <filesystem>
#include <map>
#include <ostream>
#include <string>
#include <vector>

#include "config/machine_toml.hpp"
#include "support/process.hpp"
#include "support/temp_dir.hpp"

// The layers' namespaces this file names (docs/architecture.md).
namespace config = lbpkit::config;

namespace {

namespace fs = std::filesystem;

const fs::path kCorpus = fs::path(LBPKIT_SOURCE_DIR) / "tests/pncconf/configs";

// What `lbpkit machine --from-config` cannot derive yet, by configuration:
// the message it prints (tests/pncconf/README.md lists the same). Empty:
// every configuration gives a machine.
const std::map<std::string, std::string> kNotDerivedYet = {};

struct Config {
  std::string folder;
  fs::path ini;
};

std::ostream& operator<<(std::ostream& o, const Config& c) { return o << c.folder; }

std::vector<Config> corpus() {
  std::vector<Config> out;
  for (const auto& dir : fs::directory_iterator(kCorpus)) {
    if (!dir.is_directory()) continue;
    Config c{dir.path().filename().string(), {}};
    for (const auto& f : fs::directory_iterator(dir.path()))
      if (f.path().extension() == ".ini") c.ini = f.path();
    out.push_back(c);
  }
  std::sort(out.begin(), out.end(), [](const Config& a, const Config& b) { return a.folder < b.folder; });
  return out;
}

std::string testName(const ::testing::TestParamInfo<Config>& info) {
  std::string name;
  for (const char ch : info.param.folder)
    if (std::isalnum(static_cast<unsigned char>(ch)) != 0) name += ch;
  return name;
}

class PncconfCorpus : public ::testing::TestWithParam<Config> {};

TEST_P(PncconfCorpus, ChecksWithoutAnErrorAndGivesAMachineThatLoads) {
  const auto& c = GetParam();
  ASSERT_FALSE(c.ini.empty()) << c.folder << ": no INI";

  const auto checked = test_support::run({"check-config", c.ini.string()});
  EXPECT_EQ(checked.exit, 0) << c.folder << ": lbpkit check-config " << c.ini.string() << "\n"
                             << checked.out << checked.err;
  EXPECT_NE(checked.out.find(": no problems"), std::string::npos)
      << c.folder << ": lbpkit check-config " << c.ini.string() << "\n"
      << checked.out << checked.err;

  test_support::TempDir dir;
  const auto machine = dir.path() / "machine.toml";
  const auto derived = test_support::run({"machine", "--from-config", c.ini.string(), "-o", machine.string()});
  const auto gap = kNotDerivedYet.find(c.folder);
  if (gap != kNotDerivedYet.end()) {
    EXPECT_NE(derived.exit, 0) << c.folder << ": derived a machine; update tests/pncconf/README.md and this test";
    EXPECT_NE(derived.err.find(gap->second), std::string::npos)
        << c.folder << ": expected \"" << gap->second << "\"\n"
        << derived.err;
    return;
  }
  ASSERT_EQ(derived.exit, 0) << c.folder << ": lbpkit machine --from-config " << c.ini.string() << "\n"
                             << derived.out << derived.err;
  try {
    const auto d = config::loadMachineFile(machine.string());
    EXPECT_FALSE(d.axes.empty()) << c.folder << ": the machine has no axis";
  } catch (const std::exception& e) {
    ADD_FAILURE() << c.folder << ": the machine lbpkit machine --from-config wrote does not load: " << e.what();
  }
}

INSTANTIATE_TEST_SUITE_P(Pncconf, PncconfCorpus, ::testing::ValuesIn(corpus()), testName);

// The corpus is what tests/pncconf/README.md's matrix says: ten
// configurations, none lost.
TEST(PncconfCorpusFolder, HoldsTheTenConfigurationsOfTheMatrix) { EXPECT_EQ(corpus().size(), 10U); }

}  // namespace
