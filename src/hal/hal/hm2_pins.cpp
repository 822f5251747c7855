// LinuxCNC 2.9's hostmot2 naming and pin allocation rules, as facts
// (hostmot2(9), sserial(9), and what the driver does against `lbpkit sim`:
// tests/interop_test.cpp compares this list with halcmd's, pin for pin).
#include "hal/hm2_pins.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cctype>

#include "lbpkit/wire/hostmot2.hpp"

namespace lbpkit::hal {

namespace tag = wire::hm2::tag;
namespace pinbits = wire::hm2::pin;

std::string kindName(Kind k) { return k == Kind::Pin ? "pin" : "param"; }
std::string typeName(Type t) {
  switch (t) {
    case Type::Bit: return "bit";
    case Type::Float: return "float";
    case Type::S32: return "s32";
    case Type::U32: return "u32";
  }
  return "?";
}
std::string dirName(Dir d) {
  switch (d) {
    case Dir::In: return "IN";
    case Dir::Out: return "OUT";
    case Dir::IO: return "I/O";
    case Dir::RO: return "RO";
    case Dir::RW: return "RW";
  }
  return "?";
}

namespace {

// hostmot2(9)'s config= keys that take a count.
const char* const kCountKeys[] = {"num_encoders", "num_resolvers", "num_pwmgens", "num_rcpwmgens", "num_inmuxs",
                                  "num_inms", "num_outms", "num_oneshots", "num_ssrs", "num_xy2mods",
                                  "num_3pwmgens", "num_stepgens", "stepgen_width", "num_bspis", "num_uarts",
                                  "num_pktuarts", "num_leds", "num_dplls"};

std::string lower(std::string s) {
  for (auto& c : s)
    if (c >= 'A' && c <= 'Z') c = static_cast<char>(c | 0x20);
  return s;
}

class Builder {
 public:
  void pin(std::string name, Type t, Dir d, const std::string& origin) {
    items_.push_back({std::move(name), Kind::Pin, t, d, {}, origin});
  }
  void param(std::string name, Type t, Dir d, const std::string& origin, std::string also = {}) {
    items_.push_back({std::move(name), Kind::Param, t, d, std::move(also), origin});
  }
  std::vector<Item> take() {
    std::sort(items_.begin(), items_.end(), [](const Item& a, const Item& b) { return a.name < b.name; });
    return std::move(items_);
  }

 private:
  std::vector<Item> items_;
};

// A function exported with hal_export_funct: HAL adds its time pin and tmax
// parameters.
void function(Builder& b, const std::string& name) {
  const auto origin = "function " + name;
  b.pin(name + ".time", Type::S32, Dir::Out, origin);
  b.param(name + ".tmax", Type::S32, Dir::RW, origin);
  b.param(name + ".tmax-increased", Type::Bit, Dir::RO, origin);
}

int enabled(const Hm2Config& c, const char* key, unsigned available) {
  const int n = c.count(key);
  if (n < 0) return static_cast<int>(available);
  return std::min(n, static_cast<int>(available));
}

// The name hostmot2 gives a module's output pin (its secondary function).
std::optional<std::string> secondaryName(const PinInfo& p) {
  const unsigned code = p.secondaryPin & pinbits::kCodeMask;
  switch (p.secondaryTag) {
    case tag::kMuxedQCountSel:
      if (code == 1) return "sel0";
      if (code == 2) return "sel1";
      return std::nullopt;
    case tag::kSSerial:
      if (!p.output()) return std::nullopt;
      if (code >= 0x1 && code <= 0x8) return fmt::format("tx{}", code - 1);
      if (code >= 0x11 && code <= 0x18) return fmt::format("txen{}", code - 0x11);
      return std::nullopt;
    default: return std::nullopt;
  }
}

std::optional<std::string> generalName(std::uint8_t t) {
  switch (t) {
    case tag::kQCount:
    case tag::kMuxedQCount:
    case tag::kMuxedQCountSel: return "encoder";
    case tag::kSSerial: return "sserial";
    case tag::kStepGen: return "stepgen";
    case tag::kPwm: return "pwmgen";
    default: return std::nullopt;
  }
}

void remoteItems(Builder& b, const std::string& base, const Remote& r) {
  const auto origin = fmt::format("{} on smart-serial port {} channel {} (mode {})", r.name, r.port, r.channel, r.mode);
  for (const auto& e : r.description.processData) {
    const auto name = base + "." + lower(e.name);
    const Dir d = e.direction == Direction::Input ? Dir::Out : e.direction == Direction::Output ? Dir::In : Dir::IO;
    switch (e.type) {
      case DataType::Bits:
        for (unsigned j = 0; j < e.bits; ++j) {
          const auto bit = fmt::format("{}-{:02d}", name, j);
          b.pin(bit, Type::Bit, d, origin);
          if (d == Dir::Out) b.pin(bit + "-not", Type::Bit, d, origin);
          if (d == Dir::In) b.param(bit + "-invert", Type::Bit, Dir::RW, origin);
        }
        break;
      case DataType::Unsigned:
      case DataType::Signed:
        b.pin(name, Type::Float, d, origin);
        b.param(name + "-scalemax", Type::Float, Dir::RW, origin);
        if (d != Dir::Out) {
          b.param(name + "-maxlim", Type::Float, Dir::RW, origin);
          b.param(name + "-minlim", Type::Float, Dir::RW, origin);
        }
        break;
      case DataType::Stream: b.pin(name, Type::U32, d, origin); break;
      case DataType::Boolean:
        b.pin(name, Type::Bit, d, origin);
        if (d == Dir::Out) b.pin(name + "-not", Type::Bit, d, origin);
        if (d == Dir::In) b.param(name + "-invert", Type::Bit, Dir::RW, origin);
        break;
      case DataType::Encoder:
        b.pin(name + ".count", Type::S32, Dir::Out, origin);
        b.pin(name + ".rawcounts", Type::S32, Dir::Out, origin);
        b.pin(name + ".position", Type::Float, Dir::Out, origin);
        b.pin(name + ".index-enable", Type::Bit, Dir::IO, origin);
        b.pin(name + ".reset", Type::Bit, Dir::IO, origin);
        b.param(name + ".scale", Type::Float, Dir::RW, origin);
        b.param(name + ".counts-per-rev", Type::U32, Dir::RW, origin);
        break;
      case DataType::Float: b.pin(name, Type::Float, d, origin); break;
      default: break;  // pad; non-volatile types never appear in a PTOC
    }
  }
  // The GTOC's data records not in the PTOC become parameters: read-only
  // when the remote only reports them (sserial(9)).
  for (const auto& e : r.description.parameters) {
    const auto name = base + "." + lower(e.name);
    const Dir d = e.direction == Direction::Input ? Dir::RO : Dir::RW;
    switch (e.type) {
      case DataType::Unsigned:
      case DataType::NonVolUnsigned: b.param(name, Type::U32, d, origin); break;
      case DataType::Signed:
      case DataType::NonVolSigned: b.param(name, Type::S32, d, origin); break;
      case DataType::Float:
      case DataType::NonVolFloat: b.param(name, Type::Float, d, origin); break;
      default: break;
    }
  }
}

}  // namespace

int Hm2Config::count(const std::string& key) const {
  const auto it = counts.find(key);
  return it == counts.end() ? -1 : it->second;
}

char Hm2Config::mode(unsigned port, unsigned channel) const {
  const auto it = sserialPorts.find(port);
  if (it == sserialPorts.end() || channel >= it->second.size()) return '0';
  return it->second[channel];
}

std::uint8_t Hm2Config::channelMask(unsigned port) const {
  std::uint8_t m = 0;
  for (unsigned c = 0; c < 8; ++c)
    if (mode(port, c) != 'x') m = static_cast<std::uint8_t>(m | (1U << c));
  return m;
}

std::string hm2ConfigKeys() {
  std::string s;
  for (const char* k : kCountKeys) s += std::string(k) + "=N ";
  return s + "sserial_port_N=MODES enable_raw firmware=F";
}

Hm2Config parseHm2Config(const std::string& text, std::vector<std::string>* problems) {
  Hm2Config c;
  auto problem = [&](std::string p) {
    if (problems) problems->push_back(std::move(p));
  };
  std::size_t at = 0;
  while (at < text.size()) {
    while (at < text.size() && std::isspace(static_cast<unsigned char>(text[at]))) ++at;
    if (at >= text.size()) break;
    auto end = at;
    while (end < text.size() && !std::isspace(static_cast<unsigned char>(text[end]))) ++end;
    const auto token = text.substr(at, end - at);
    at = end;
    const auto eq = token.find('=');
    const auto key = token.substr(0, eq);
    const auto value = eq == std::string::npos ? std::string() : token.substr(eq + 1);
    if (key.rfind("sserial_port_", 0) == 0) {
      const auto n = key.substr(13);
      if (n.size() != 1 || n[0] < '0' || n[0] > '3' || eq == std::string::npos) {
        problem(fmt::format("\"{}\": hostmot2 wants sserial_port_N=MODES with N 0..3", token));
        continue;
      }
      std::string modes;
      for (char ch : value) {
        if (((ch >= '0' && ch <= '9') || ch == 'x') && modes.size() < 8) modes += ch;
        else if (!(ch >= '0' && ch <= '9') && ch != 'x')
          problem(fmt::format("\"{}\": '{}' is neither a mode digit nor x (hostmot2 ignores it)", token, ch));
      }
      c.sserialPorts[static_cast<unsigned>(n[0] - '0')] = modes;
      c.sserialPortGiven = true;
      continue;
    }
    if (key == "enable_raw" || key == "firmware") continue;
    if (std::find_if(std::begin(kCountKeys), std::end(kCountKeys), [&](const char* k) { return key == k; }) ==
        std::end(kCountKeys)) {
      problem(fmt::format("\"{}\" is not a hostmot2 config= key (it knows: {})", key, hm2ConfigKeys()));
      continue;
    }
    char* stop = nullptr;
    const long v = std::strtol(value.c_str(), &stop, 0);
    if (value.empty() || *stop != '\0') {
      problem(fmt::format("\"{}\": {} wants a number", token, key));
      continue;
    }
    c.counts[key] = static_cast<int>(v);
  }
  return c;
}

std::string boardPrefix(const CardInfo& card, unsigned index) {
  std::string name = card.boardName;
  if (name.rfind("MESA", 0) == 0) name = name.substr(4);
  return fmt::format("hm2_{}.{}", lower(name), index);
}

unsigned ledCount(const std::string& boardName) {
  const auto b = lower(boardName);
  if (b.find("5i25") != std::string::npos || b.find("6i25") != std::string::npos) return 2;
  if (b.find("7i92") != std::string::npos || b.find("7i76e") != std::string::npos ||
      b.find("7i96") != std::string::npos)
    return 4;
  return 0;
}

std::vector<Item> hostmot2Items(const CardInfo& card, const Hm2Config& config, const std::vector<Remote>& remotes,
                                Driver driver, unsigned boardIndex) {
  Builder b;
  const auto p = boardPrefix(card, boardIndex);
  const std::string board = "the board";

  b.param(p + ".io_error", Type::Bit, Dir::RW, board);
  if (driver == Driver::Eth) {
    b.pin(p + ".packet-error", Type::Bit, Dir::Out, board);
    b.pin(p + ".packet-error-exceeded", Type::Bit, Dir::Out, board);
    b.pin(p + ".packet-error-level", Type::S32, Dir::Out, board);
    b.pin(p + ".packet-error-total", Type::U32, Dir::IO, board);
    b.param(p + ".packet-error-decrement", Type::S32, Dir::RO, board);
    b.param(p + ".packet-error-increment", Type::S32, Dir::RW, board);
    b.param(p + ".packet-error-limit", Type::S32, Dir::RW, board);
    b.param(p + ".packet-read-timeout", Type::S32, Dir::RW, board);
    function(b, p + ".read-request");  // hm2_eth splits the read
    function(b, p + ".read");
    function(b, p + ".write");
  } else {
    function(b, p + ".read");
    function(b, p + ".write");
    function(b, p + ".read_gpio");  // the PCI driver is thread-safe
    function(b, p + ".write_gpio");
  }

  if (card.module(tag::kWatchdog)) {
    b.pin(p + ".watchdog.has_bit", Type::Bit, Dir::IO, "the watchdog");
    b.param(p + ".watchdog.timeout_ns", Type::U32, Dir::RW, "the watchdog");
  }
  if (card.module(tag::kLed)) {
    const int n = enabled(config, "num_leds", ledCount(card.boardName));
    for (int i = 0; i < n; ++i) b.pin(fmt::format("{}.led.CR{:02d}", p, i + 1), Type::Bit, Dir::In, "the LEDs");
  }

  // Encoders (QCount or MuxedQCount: one "encoder" set of names).
  const ModuleInfo* enc = card.module(tag::kMuxedQCount);
  const bool muxed = enc != nullptr;
  if (!enc) enc = card.module(tag::kQCount);
  const int encoders = enc ? enabled(config, "num_encoders", enc->instances) : 0;
  for (int i = 0; i < encoders; ++i) {
    const auto e = fmt::format("{}.encoder.{:02d}", p, i);
    const auto origin = fmt::format("encoder {}", i);
    for (const char* s : {"count", "count-latched", "rawcounts", "rawlatch"}) b.pin(e + "." + s, Type::S32, Dir::Out, origin);
    for (const char* s : {"input-a", "input-b", "input-index", "quad-error"}) b.pin(e + "." + s, Type::Bit, Dir::Out, origin);
    for (const char* s : {"position", "position-latched", "velocity", "velocity-rpm"})
      b.pin(e + "." + s, Type::Float, Dir::Out, origin);
    b.pin(e + ".index-enable", Type::Bit, Dir::IO, origin);
    b.pin(e + ".quad-error-enable", Type::Bit, Dir::In, origin);
    b.pin(e + ".reset", Type::Bit, Dir::In, origin);
    for (const char* s : {"counter-mode", "filter", "index-invert", "index-mask", "index-mask-invert"})
      b.param(e + "." + s, Type::Bit, Dir::RW, origin);
    b.param(e + ".scale", Type::Float, Dir::RW, origin);
    b.param(e + ".vel-timeout", Type::Float, Dir::RW, origin);
  }
  if (encoders > 0) {
    b.pin(p + ".encoder.hires-timestamp", Type::Bit, Dir::In, "the encoders");
    b.pin(p + (muxed ? ".encoder.muxed-sample-frequency" : ".encoder.sample-frequency"), Type::U32, Dir::In,
          "the encoders");
  }

  // Smart-serial ports: those the configuration names with a mode digit
  // (all of them when it names none).
  const ModuleInfo* ss = card.module(tag::kSSerial);
  unsigned ports = ss ? ss->instances : 0;
  if (config.sserialPortGiven) {
    unsigned n = 0;
    for (const auto& [port, modes] : config.sserialPorts)
      if (modes.find_first_of("0123456789") != std::string::npos) n = std::max(n, port + 1);
    ports = std::min(ports, n);
  }
  auto remoteAt = [&](unsigned port, unsigned channel) -> const Remote* {
    for (const auto& r : remotes)
      if (r.port == port && r.channel == channel) return &r;
    return nullptr;
  };
  for (unsigned i = 0; i < ports; ++i) {
    const auto origin = fmt::format("smart-serial port {}", i);
    const auto s = fmt::format("{}.sserial.port-{}", p, i);
    b.pin(fmt::format("{}.{}.debug", p, i), Type::S32, Dir::Out, origin);
    b.pin(s + ".run", Type::Bit, Dir::In, origin);
    for (const char* n : {"port_state", "port_state2", "port_state3", "fault-count"}) b.pin(s + "." + n, Type::U32, Dir::Out, origin);
    for (const char* n : {"fault-inc", "fault-dec", "fault-lim"}) b.param(s + "." + n, Type::U32, Dir::RW, origin);
    for (const auto& r : remotes) {
      if (r.port != i || config.mode(i, r.channel) == 'x') continue;
      std::string raw = r.name;
      if (raw.size() > 1) raw[1] = static_cast<char>(raw[1] | 0x20);  // as the driver lower-cases it
      remoteItems(b, fmt::format("{}.{}.{}.{}", p, raw, i, r.channel), r);
    }
  }

  // IO pins: every one reads as gpio.NNN.in/in_not; a pin no enabled module
  // takes is a full GPIO; a module's output pin gets its output parameters
  // under the module's name too.
  std::vector<std::uint8_t> gtag(card.pins.size(), tag::kIoPort);
  for (std::size_t i = 0; i < card.pins.size(); ++i) {
    const auto& pin = card.pins[i];
    const unsigned unit = pin.secondaryUnit;
    const bool global = (unit & 0x80) != 0;
    auto upTo = [&](int n) { return (global && n > 0) || static_cast<int>(unit) < n; };
    bool taken = false;
    switch (pin.secondaryTag) {
      case tag::kQCount: taken = upTo(encoders); break;
      case tag::kMuxedQCount: taken = upTo((encoders + 1) / 2); break;
      case tag::kMuxedQCountSel: taken = upTo(encoders); break;
      case tag::kSSerial: {
        const unsigned ch = (pin.secondaryPin & pinbits::kSSerialChannelMask) - 1U;
        taken = unit < ports && config.mode(unit, ch) != 'x' && remoteAt(unit, ch) != nullptr;
        break;
      }
      case tag::kStepGen:
        if (const auto* m = card.module(tag::kStepGen)) taken = upTo(enabled(config, "num_stepgens", m->instances));
        break;
      case tag::kPwm:
        if (const auto* m = card.module(tag::kPwm)) taken = upTo(enabled(config, "num_pwmgens", m->instances));
        break;
      default: break;
    }
    if (taken) gtag[i] = pin.secondaryTag;
  }
  for (std::size_t i = 0; i < card.pins.size(); ++i) {
    const auto& pin = card.pins[i];
    const auto g = fmt::format("{}.gpio.{:03d}", p, i);
    const auto origin = fmt::format("IO pin {} (connector {} pin {}): {}", i, pin.connector, pin.bit,
                                    gtag[i] == tag::kIoPort ? std::string("GPIO") : pin.function());
    b.pin(g + ".in", Type::Bit, Dir::Out, origin);
    b.pin(g + ".in_not", Type::Bit, Dir::Out, origin);
    if (gtag[i] == tag::kIoPort) {
      b.pin(g + ".out", Type::Bit, Dir::In, origin);
      for (const char* n : {"invert_output", "is_opendrain", "is_output"}) b.param(g + "." + n, Type::Bit, Dir::RW, origin);
      continue;
    }
    if (!pin.output()) continue;
    const auto general = generalName(gtag[i]);
    const auto function = secondaryName(pin);
    if (!general || !function) {
      for (const char* n : {"invert_output", "is_opendrain"}) b.param(g + "." + n, Type::Bit, Dir::RW, origin);
      continue;
    }
    // Pins of one unit with the same function: numbered when more than one.
    unsigned total = 0, mine = 0;
    for (std::size_t j = 0; j < card.pins.size(); ++j) {
      if (j == i) mine = total;
      if (gtag[j] == gtag[i] && card.pins[j].secondaryUnit == pin.secondaryUnit &&
          card.pins[j].secondaryPin == pin.secondaryPin)
        ++total;
    }
    const auto alias = total == 1 ? fmt::format("{}.{}.{:02d}.{}", p, *general, pin.secondaryUnit, *function)
                                  : fmt::format("{}.{}.{:02d}.{}.{}", p, *general, pin.secondaryUnit, mine, *function);
    for (const char* n : {"invert_output", "is_opendrain"})
      b.param(alias + "." + n, Type::Bit, Dir::RW, origin, g + "." + n);
  }
  return b.take();
}

}  // namespace lbpkit::hal
