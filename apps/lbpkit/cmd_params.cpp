// SPDX-License-Identifier: MIT
// lbpkit rpd / wpd: read and write a remote's parameters by name, like
// Mesa's RPD and WPD (manual: RPD, WPD, AND UFLBP).
#include <fcntl.h>
#include <fmt/core.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <functional>
#include <memory>
#include <optional>
#include <vector>

#include "common.hpp"
#include "lbpkit/error.hpp"
#include "lbpkit/parameters.hpp"
#include "lbpkit/remote_flash.hpp"
#include "lbpkit/serial_remote.hpp"
#include "lbpkit/wire/seven_i77.hpp"

// The layers' namespaces this file names (docs/architecture.md).
namespace app = lbpkit::app;

namespace lbpkit::app {
extern std::function<int()> gRun;
}

namespace {

struct ParamOptions {
  app::CardOptions card;
  std::string name;
  std::string value;
  std::string hex;  // "H" as RPD/WPD take it
  unsigned channel = 0;
  std::string serial;
  std::string file;     // flash-remote: the firmware image
  bool noVerify = false;
};

// The remote to talk to and its description, from a card or a serial line.
struct Target {
  Target() = default;
  Target(Target&&) = default;
  Target& operator=(Target&&) = delete;
  Target(const Target&) = delete;
  // The channel's baud rate as it was, when a firmware update changed it:
  // SSLBP keeps what it is given until the FPGA is reset, and the next
  // tool (or LinuxCNC) expects the card as it found it.
  ~Target() {
    if (!restoreBaud || !ss) return;
    try {
      ss->setBaudRate(channel, *restoreBaud);
      ss->stopAll();
    } catch (const std::exception&) {  // the card is gone: nothing to restore
    }
  }
  app::Card card;
  std::unique_ptr<lbpkit::SmartSerial> ss;
  std::unique_ptr<lbpkit::RemoteAccess> access;
  lbpkit::RemoteDescription description;
  unsigned channel = 0;
  std::optional<std::uint32_t> restoreBaud;
};

// `setupBaud`: the channel at setup mode's 115200 baud first (a 7I77 with
// W4/W12 set answers only there), for a firmware update.
Target open(const ParamOptions& o, bool setupBaud = false) {
  Target t;
  if (!o.serial.empty()) {
    auto sr = std::make_unique<lbpkit::SerialRemote>(o.serial);
    const auto d = sr->discoveryRpc();
    t.description = lbpkit::discover(*sr, d.ptoc, d.gtoc, d.rxSize, d.txSize);
    t.access = std::move(sr);
    return t;
  }
  t.card = app::openCard(o.card);
  const unsigned channels = std::max(1U, t.card.info.sserialChannels());
  if (o.channel >= channels)
    throw lbpkit::Error(fmt::format("--channel {}: this card has smart-serial channels 0..{}", o.channel, channels - 1));
  auto options = o.card.serialOptions();
  options.channelMask = static_cast<std::uint8_t>(1U << o.channel);
  t.ss = std::make_unique<lbpkit::SmartSerial>(*t.card.transport, t.card.info, options);
  t.channel = o.channel;
  if (setupBaud) {
    t.restoreBaud = t.ss->baudRate(o.channel);
    t.ss->setBaudRate(o.channel, lbpkit::wire::i7i77::kSetupBaud);
  }
  t.ss->stopAll();
  if (t.ss->start(options.channelMask, true))
    throw lbpkit::Error(fmt::format("no remote answers on channel {} (setup START failed{})", o.channel,
                                    setupBaud ? " at 115200 baud: is the remote in setup mode, W12 or W4?" : ""));
  const auto id = t.ss->identity(o.channel);
  t.access = t.ss->remote(o.channel);
  if (!setupBaud) t.description = lbpkit::discover(*t.access, id.ptoc, id.gtoc);
  return t;
}

const char* fileKind(mode_t mode) {
  if (S_ISDIR(mode)) return "a folder";
  if (S_ISFIFO(mode)) return "a FIFO";
  if (S_ISCHR(mode)) return "a character device";
  if (S_ISBLK(mode)) return "a block device";
  if (S_ISSOCK(mode)) return "a socket";
  return "not a regular file";
}

std::string tooLarge(const std::string& file, std::size_t bytes) {
  constexpr std::size_t flash = lbpkit::wire::i7i77::kProgramFlashBytes;
  return fmt::format("{}: {} bytes, larger than the 7I77 processor's {}-byte ({} KiB) program flash: not a firmware "
                     "image for it; nothing was erased",
                     file, bytes, flash, flash / 1024);
}

// The firmware image, whole, before the remote is touched: a regular file no
// larger than the flash. Opened without blocking (a FIFO with no writer
// would hold the open) and checked for what it is before a byte is read;
// never more than the flash's size plus one is read (a file that grows).
std::vector<std::uint8_t> readImage(const std::string& file) {
  constexpr std::size_t bound = lbpkit::wire::i7i77::kProgramFlashBytes;
  const int fd = ::open(file.c_str(), O_RDONLY | O_NONBLOCK | O_NOCTTY | O_CLOEXEC);
  if (fd < 0) throw lbpkit::Error(fmt::format("{}: cannot read it: {}", file, std::strerror(errno)));
  struct Closer {
    int fd;
    ~Closer() { ::close(fd); }
  } closer{fd};
  struct stat st {};
  if (::fstat(fd, &st) != 0) throw lbpkit::Error(fmt::format("{}: cannot read it: {}", file, std::strerror(errno)));
  if (!S_ISREG(st.st_mode))
    throw lbpkit::Error(fmt::format("{}: is {}, not a firmware image file (flash-remote reads regular files only)",
                                    file, fileKind(st.st_mode)));
  if (static_cast<std::uintmax_t>(st.st_size) > bound)
    throw lbpkit::Error(tooLarge(file, static_cast<std::size_t>(st.st_size)));
  std::vector<std::uint8_t> image(bound + 1);
  std::size_t got = 0;
  while (got < image.size()) {
    const ssize_t n = ::read(fd, image.data() + got, image.size() - got);
    if (n < 0 && errno == EINTR) continue;
    if (n < 0) throw lbpkit::Error(fmt::format("{}: cannot read it: {}", file, std::strerror(errno)));
    if (n == 0) break;
    got += static_cast<std::size_t>(n);
  }
  if (got > bound) throw lbpkit::Error(tooLarge(file, got) + " (the file grew while it was read)");
  if (got == 0) throw lbpkit::Error(fmt::format("{}: the file is empty", file));
  image.resize(got);
  return image;
}

// lbpkit flash-remote FILE: UFLBP's update, with each commit checked and the
// flash read back (docs/tools.md#a-remotes-firmware-flash-remote).
int runFlashRemote(const ParamOptions& o) {
  const std::vector<std::uint8_t> image = readImage(o.file);
  auto t = open(o, true);
  const auto g = lbpkit::flashGeometry(*t.access);
  fmt::print("{}: {} bytes to {}: flash of {}-byte blocks in {}-byte pages\n", o.file, image.size(), t.access->where(),
             g.eraseBytes, g.writeBytes);
  const auto written = lbpkit::flashRemote(*t.access, image, !o.noVerify, [](const lbpkit::FlashProgress& p) {
    using Step = lbpkit::FlashProgress::Step;
    const char* what = p.step == Step::Erased    ? "erased"
                       : p.step == Step::Written ? "written"
                       : p.step == Step::Skipped ? "skipped (all zero)"
                                                 : "verified";
    fmt::print("  block {}/{} {}\n", p.block, p.blocks - 1, what);
    std::fflush(stdout);
  });
  fmt::print("{} blocks written{}: the remote runs the new firmware after a power cycle (setup jumper back first)\n",
             written, o.noVerify ? "" : " and read back as the file");
  return 0;
}

const lbpkit::ProcessDataElement& lookup(const Target& t, const std::string& name) {
  if (const auto* e = t.description.find(name)) return *e;
  std::string names;
  for (const auto* list : {&t.description.parameters, &t.description.processData})
    for (const auto& e : *list) names += " " + e.name;
  throw lbpkit::Error(fmt::format("{} has no parameter \"{}\"; it has:{}", t.access->where(), name, names));
}

bool hexFlag(const std::string& h) {
  if (h.empty()) return false;
  if (h == "H" || h == "h") return true;
  throw lbpkit::Error(fmt::format("\"{}\": the only format letter is H (hexadecimal)", h));
}

int runRpd(const ParamOptions& o) {
  const bool hex = hexFlag(o.hex);
  auto t = open(o);
  const auto& e = lookup(t, o.name);
  fmt::print("{}\n", lbpkit::formatElement(e, lbpkit::readElement(*t.access, e), hex));
  return 0;
}

int runWpd(const ParamOptions& o) {
  const bool hex = hexFlag(o.hex);
  auto t = open(o);
  const auto& e = lookup(t, o.name);
  if (e.direction == lbpkit::Direction::Input && !lbpkit::isNonVolatile(e.type))
    throw lbpkit::Error(fmt::format("{} is read only", e.name));
  const auto raw = lbpkit::parseElement(e, o.value, hex);
  lbpkit::writeElement(*t.access, e, raw);
  if (lbpkit::isNonVolatile(e.type))
    fmt::print("{} = {} written to the EEPROM: it takes effect after a power cycle\n", e.name,
               lbpkit::formatElement(e, raw, hex));
  else
    fmt::print("{} = {}\n", e.name, lbpkit::formatElement(e, raw, hex));
  return 0;
}

void common(CLI::App* cmd, ParamOptions& o) {
  o.card.add(*cmd);
  cmd->add_option("--channel", o.channel, "Smart-serial channel of the remote (0: 7I77 field I/O, 1: analog)")
      ->capture_default_str();
  cmd->add_option("--serial", o.serial,
                  "Talk LBP straight to a remote on this serial device (setup mode, 115200 baud), e.g. the pty of "
                  "lbpkit remote --pty");
}

}  // namespace

void addParameterCommands(CLI::App& app) {
  auto r = std::make_shared<ParamOptions>();
  auto* rpd = app.add_subcommand("rpd", "Read a remote parameter by name, like Mesa's RPD (e.g. rpd FAULT H)");
  rpd->add_option("name", r->name, "Parameter name (case does not matter; the manual's spellings work)")->required();
  rpd->add_option("format", r->hex, "H for hexadecimal");
  common(rpd, *r);
  rpd->callback([r] { app::gRun = [r] { return runRpd(*r); }; });

  auto w = std::make_shared<ParamOptions>();
  auto* wpd = app.add_subcommand("wpd", "Write a remote parameter by name, like Mesa's WPD (e.g. wpd WATCHDOGTIME 0)");
  wpd->add_option("name", w->name, "Parameter name")->required();
  wpd->add_option("value", w->value, "New value (decimal, 0x.. or hex with H)")->required();
  wpd->add_option("format", w->hex, "H for hexadecimal");
  common(wpd, *w);
  wpd->callback([w] { app::gRun = [w] { return runWpd(*w); }; });

  auto f = std::make_shared<ParamOptions>();
  auto* flash = app.add_subcommand(
      "flash-remote", "Update a remote's firmware, like Mesa's UFLBP and LinuxCNC's setsserial flash, and read it back "
                      "(the remote in setup mode: W12 or W4)");
  flash->add_option("file", f->file, "The firmware image (.BIN)")->required();
  flash->add_flag("--no-verify", f->noVerify, "Do not read the flash back (setsserial does not)");
  common(flash, *f);
  flash->callback([f] { app::gRun = [f] { return runFlashRemote(*f); }; });
}
