// SPDX-License-Identifier: MIT
// What every part of lbpkit machine --from-config shares: reading a number,
// a bit or a name as a LinuxCNC INI or HAL file writes it; where a hostmot2
// pin sits on a 7I77's or 7I76's terminals (the 7I77 manual: 32 field
// inputs, 16 outputs, 6 analog outputs; hostmot2(9)'s pin names); the
// bounds a derived machine's values keep to; and the sink that collects
// what is said about a configuration (errors and warnings at a file and
// line).
#pragma once

#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "linuxcnc/hal_config.hpp"
#include "linuxcnc/machine_from_config.hpp"

namespace lbpkit::linuxcnc::detail {

std::vector<std::string> split(const std::string& s, char by);
// A number as written, inf and nan included: the bounds each use puts on
// it (Bound below) refuse those with the key that holds them.
std::optional<double> number(const std::string& s);
std::string lower(std::string s);
// An INI truth value: YES, TRUE or 1.
bool yes(const std::string& s);

// The joints LinuxCNC's motion controller has room for: EMCMOT_MAX_JOINTS
// (src/emc/motion/emcmotcfg.h, 16 since LinuxCNC 2.8); [KINS]JOINTS past it
// is refused by LinuxCNC at start.
inline constexpr unsigned kMaxJoints = 16;

// What a machine can have, each bound far past any real machine and inside
// what a machine file takes (src/config/config/machine_toml.cpp), so that a
// value within them gives a machine file that loads:
// - a scale (encoder counts, steps per unit): |scale| 1e-6 to 1e9, a
//   nanometre scale gives 1e6 counts/mm;
// - an analog output's scale (units/s, or rpm, at 10 V): 1e-6 to 1e9;
// - a velocity: at most 1e5 units/s (100 m/s in mm);
// - an acceleration: at most 1e7 units/s^2 (1e7 mm/s^2 is a thousand g);
// - a position (limits, HOME_OFFSET): within 1e5 mm (100 m) of 0; a rotary
//   joint's "unlimited" limits (-9999999) are taken as +-1e5 degrees.
// What a derived value must stay within (the machine file's own bounds) is
// checked where it is worked out, naming the INI keys it comes from.
struct Bound {
  double low, high;   // on |v|; low 0 allows 0
  const char* what;   // "a scale"
  const char* range;  // "|scale| between 1e-6 and 1e9 counts per unit"
};
inline constexpr Bound kScaleBound{1e-6, 1e9, "a scale", "|scale| between 1e-6 and 1e9 counts or steps per unit"};
inline constexpr Bound kOutputScaleBound{1e-6, 1e9, "an output scale",
                                         "|scale| between 1e-6 and 1e9 units/s (or rpm) at 10 V"};
inline constexpr Bound kVelocityBound{0.0, 1e5, "a velocity", "|velocity| at most 1e5 units/s"};
inline constexpr Bound kAccelerationBound{0.0, 1e7, "an acceleration", "at most 1e7 units/s^2"};
inline constexpr Bound kFf1Bound{0.0, 1e6, "a feed-forward", "|FF1| at most 1e6"};
inline constexpr double kMaxPositionMm = 1e5;

// The 7I77's and 7I76's terminals (the 7I77 manual: 32 inputs, 16 outputs,
// 6 analog outputs, the 7I92's 7I77 firmware's 6 encoders; the 7I76 manual:
// 32 inputs, 16 outputs), hostmot2's at most 16 StepGens, and a card's IO
// pins (at most 6 ports of 24).
inline constexpr unsigned kFieldInputs = 32, kFieldOutputs = 16, kAnalogOutputs = 6, kEncoders = 6, kStepGens = 16,
                          kCardPins = 144;

// The limits of a machine file (src/config/config/machine_toml.cpp) a
// derived value must meet.
inline constexpr double kMaxEncoderLines = 1e6, kMinGear = 1e-3, kMaxGear = 1e3, kMinGain = 1e-6, kMaxLimit = 1e4,
                        kMinStepsPerMm = 1e-3, kMaxStepsPerMm = 1e6, kMaxStepRate = 1e7, kMaxOvertravel = 1e4,
                        kMinRpmPerVolt = 1e-3, kMaxRpmPerVolt = 1e5, kMaxRpm = 1e6;

// A machine's name from a file's: what a machine file's name allows (1 to
// 40 letters, digits, '_' or '-'; config/toml_reader.hpp), anything else a
// '-'.
std::string machineName(const std::string& stem);
// Text for a TOML comment: one line of valid UTF-8 with no control
// character (what TOML allows in a comment), each byte that is not '?'.
std::string commentText(const std::string& s);
// A number as the machine file writes it: whole numbers with ".0", others
// to six significant digits.
std::string fmtNumber(double v);
// Where something is written, for a message: "file:line".
std::string at(const Where& w);

// Where a 7I77 pin sits: hm2_<card>.<n>.7i77.<port>.<channel>.<pin>. The
// 7I77 firmwares have one smart-serial port of 6 channels (docs/cards.md):
// the first 7I77 answers on channel 0 (field I/O) and 1 (analog outputs), a
// second 7I77 on 3 and 4; channels 2 and 5 are their expansion ports. A
// machine file's machine sits behind the first 7I77 (connector 0). Empty
// for a field input, output or analog output of the first 7I77 (or a pin of
// no 7I77), else why the derived machine has no such terminal.
std::string offFirst7I77(const std::string& pin);

// A pin of a 7I77's or 7I76's field I/O: hm2_<card>.<n>.<7i77|7i76>.<port>.<channel>.<input-NN[-not]|output-NN>,
// or an input on one of the card's own IO pins.
struct FieldPin {
  std::string daughtercard;  // "7I77", "7I76", "card"
  unsigned number = 0;
  bool inverted = false;  // input-NN-not
};
// `what`: "input" or "output".
std::optional<FieldPin> fieldPin(const std::string& pin, const std::string& what);
// hm2_<card>.<n>.<module>.NN.<leaf> -> NN
std::optional<unsigned> modulePin(const std::string& pin, const std::string& module, const std::string& leaf);
// hm2_<card>.<n>.7i77.<port>.<channel>.analogoutK -> K: the first 7I77's
// (any 7I77's with anyChannel).
std::optional<unsigned> analogOut(const std::string& pin, bool anyChannel = false);
// The board a pin is on: "hm2_7i92.0", or "".
std::string cardOf(const std::string& pin);

// The encoder lines a motor turn gives `countsPerMm` on a screw of `pitch`
// mm: whole lines, and the gear ratio (motor turns per screw turn) that
// makes the counts exact where the pitch alone does not.
struct Lines {
  unsigned long lines = 1;
  double gear = 1.0;
};
Lines encoderLines(double countsPerMm, double pitch);

// A value the configuration gives, and where it says so: `from` for the
// machine file's comment, `said` (the key or setp as written) and `at` for
// an error (machine_from_config.hpp).
using Value = ConfigValue;

// Where the findings about a configuration go, in the order they are
// found; an error means no machine is written.
class Diagnostics {
 public:
  explicit Diagnostics(std::vector<Finding>& findings) : findings_(findings) {}
  void error(const Where& w, const std::string& name, const std::string& reason);
  void warning(const Where& w, const std::string& name, const std::string& reason);
  [[nodiscard]] bool failed() const { return failed_; }

 private:
  std::vector<Finding>& findings_;
  bool failed_ = false;
};

}  // namespace lbpkit::linuxcnc::detail
