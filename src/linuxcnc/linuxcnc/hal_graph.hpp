// SPDX-License-Identifier: MIT
// A configuration's HAL signal graph (halcmd(1): loadrt, net, setp, sets):
// which pins each signal joins, which component instance each pin belongs
// to, and what each bit pin reads once the field inputs have rested, as the
// components between a switch and what it stops compute it (LinuxCNC's
// src/hal/components/: not, and2, or2, xor2, logic, debounce, timedelay,
// estop_latch, oneshot, edge, toggle). From it: the field inputs whose
// state reaches a pin (trace), and the resting states of the inputs that
// hold an interlock the way the machine runs (hold). It knows HAL, not
// machines.
#pragma once

#include <cstddef>
#include <filesystem>
#include <map>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include "linuxcnc/derive_common.hpp"
#include "linuxcnc/hal_config.hpp"

namespace lbpkit::linuxcnc::detail {

// A field input whose state reaches a pin, and whether it arrives inverted
// (an odd number of `not`s and input-NN-not on the way).
struct Source {
  std::string pin;
  FieldPin field;
  bool inverted = false;
};

// An input's state at rest, chosen so that an interlock reads the way the
// machine runs, or given by the switch on it.
struct Held {
  bool on = false;
  std::string pin;      // the field pin, as netted
  std::string through;  // the components on the way ("debounce.0.0, not.0")
  std::string reason;   // "motion.feed-inhibit to be FALSE", "the x-min switch"
  Where at;             // where that is netted
};
using Holds = std::map<std::string, Held>;  // "7I77:12" -> its state

// Something that must read one way for the machine to run.
struct Interlock {
  std::string pin;
  bool want = false;
  std::string what;  // "motion.feed-inhibit to be FALSE"
};

class HalGraph {
 public:
  // `ini`: the configuration's INI, named where no HAL line names a pin.
  HalGraph(const HalConfig& hal, std::filesystem::path ini);

  // Each pin on a signal, and its signal.
  [[nodiscard]] const std::map<std::string, std::string>& pinSignal() const { return pinSignal_; }
  // Each component instance loaded ("not.0", "debounce.0.3"), and its module.
  [[nodiscard]] const std::map<std::string, std::string>& instanceModule() const { return instanceModule_; }
  // What a `message` instance shows (its loadrt's messages=), or "".
  [[nodiscard]] std::string messageText(const std::string& instance) const;

  // The signal a pin is on, or "".
  [[nodiscard]] std::string signal(const std::string& pin) const;
  [[nodiscard]] const std::vector<std::string>& pinsOn(const std::string& signal) const;
  // The first line that names a pin (the INI when none does).
  [[nodiscard]] Where where(const std::string& pin) const;
  // Where `pin` is put on `signal`.
  [[nodiscard]] Where whereOn(const std::string& pin, const std::string& signal) const;
  // Where a pin is connected, for a message: "signal S, with A, B".
  [[nodiscard]] std::string describe(const std::string& pin) const;
  // The module of a component instance, or "".
  [[nodiscard]] std::string moduleOf(const std::string& instance) const;

  // A bit as HAL's `setp` and `sets` take it: 1/0, TRUE/FALSE.
  static std::optional<bool> bit(const std::string& s);

  // The field inputs whose state reaches `pin`, and whether each arrives
  // inverted (an odd number of `not`s, nand, nor, fault-in and
  // input-NN-not on the way).
  void trace(const std::string& pin, bool inverted, std::vector<Source>& out);

  // Holds `i` by the inputs' states, given those already held (`current`):
  // the states it adds, or nullopt (and a warning to `diag` saying why)
  // when none does.
  std::optional<Holds> hold(const Interlock& i, const Holds& current, Diagnostics& diag);

 private:
  // What HAL makes of the field inputs at rest: each bit pin a configuration
  // reads, as the components between a switch and what it stops compute it
  // once the inputs have stayed as they are for a while. A node is one of
  // those values.
  struct Node {
    enum class Kind { Const, Input, Not, And, Or, Xor, Unknown };
    Kind kind = Kind::Unknown;
    bool value = false;  // Const
    std::string pin;     // Input: the field pin as netted
    FieldPin field;      // Input (inverted: input-NN-not)
    std::string label;   // the component it is the output of ("not.0"), for a path
    std::vector<std::size_t> kids;
    std::string why;  // Const, Unknown: what it is
  };
  static constexpr unsigned kMaxDepth = 64;        // components in a row
  static constexpr std::size_t kMaxNodes = 20000;  // values in a configuration

  // Steps a search may take: a configuration's logic needs a few hundred;
  // one built to branch without end stops here.
  static constexpr unsigned kSteps = 20000;
  struct Search {
    Holds holds;
    const Interlock* for_ = nullptr;
    unsigned budget = kSteps;
    std::vector<std::string> path;
  };

  std::size_t add(Node n);
  std::size_t constant(bool v, std::string why);
  std::size_t unknown(std::string why);
  std::size_t gate(Node::Kind k, std::string label, std::vector<std::size_t> kids);
  // The value pin `pin` (one that reads a signal) has at rest.
  std::size_t nodeFor(const std::string& pin, unsigned depth = 0);
  std::size_t computeNode(const std::string& pin, unsigned depth);
  // The value of a component's output pin `p`; nullopt when `p` is no
  // output of a component followed here (another reader of the signal).
  std::optional<std::size_t> outputNode(const std::string& p, unsigned depth);
  static std::string key(const FieldPin& f);
  // Makes node `id` read `want` by choosing inputs' states in `s.holds`:
  // false when it cannot. `lax`: a value lbpkit cannot follow (a signal
  // from motion, a ladder) is taken to read as wanted.
  bool require(std::size_t id, bool want, bool lax, Search& s);
  bool requireXor(const std::vector<std::size_t>& kids, std::size_t from, bool want, bool lax, Search& s);

  const HalConfig& hal_;
  std::filesystem::path ini_;
  std::map<std::string, std::string> instanceModule_;
  std::map<std::string, unsigned> personality_;     // logic instance -> its personality
  std::map<std::string, std::string> messageText_;  // message instance -> what it shows
  std::map<std::string, std::string> pinSignal_;
  std::vector<Node> nodes_;
  std::map<std::string, std::size_t> nodeOf_;  // pin -> its value at rest
  std::set<std::string> building_;
};

}  // namespace lbpkit::linuxcnc::detail
