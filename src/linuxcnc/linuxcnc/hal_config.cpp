// halcmd(1): INI substitution, comments, continued lines, quoting; the
// INI's [HAL] section (LinuxCNC's INI documentation).
#include "linuxcnc/hal_config.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cctype>
#include <fstream>
#include <optional>
#include <utility>

namespace lbpkit::linuxcnc {

std::string trim(const std::string& s) {
  const auto b = s.find_first_not_of(" \t\r\n");
  if (b == std::string::npos) return {};
  return s.substr(b, s.find_last_not_of(" \t\r\n") - b + 1);
}

const IniEntry* Ini::find(const std::string& section, const std::string& key) const {
  const auto s = sections.find(section);
  if (s == sections.end()) return nullptr;
  const auto k = s->second.find(key);
  return k == s->second.end() ? nullptr : &k->second;
}

std::string HalConfig::signalOf(const std::string& pin) const {
  for (const auto& [signal, pins] : signals)
    if (std::find(pins.begin(), pins.end(), pin) != pins.end()) return signal;
  return {};
}

const Setp* HalConfig::setpOf(const std::string& name) const {
  for (auto it = setps.rbegin(); it != setps.rend(); ++it)
    if (it->name == name) return &*it;
  return nullptr;
}

namespace {

// Bounds on what is read: a configuration's files are kilobytes.
constexpr std::uintmax_t kMaxFileBytes = 16U << 20;
constexpr std::size_t kMaxLineBytes = 64U << 10;

// Why `path` cannot be read as a configuration file; empty when it can.
// Only a regular file (or a link to one) is read: a directory, a FIFO or a
// device is nothing LinuxCNC loads, and reading one could hang or never end.
std::string unreadable(const std::filesystem::path& path) {
  namespace fs = std::filesystem;
  std::error_code ec;
  const auto st = fs::status(path, ec);
  if (ec || !fs::exists(st)) return "no such file";
  if (fs::is_directory(st)) return "a directory, not a file";
  if (!fs::is_regular_file(st)) return "not a regular file (a FIFO, a socket or a device)";
  const auto size = fs::file_size(path, ec);
  if (ec) return "cannot be read";
  if (size > kMaxFileBytes)
    return fmt::format("{} bytes, more than the {} MiB lbpkit check-config reads", size, kMaxFileBytes >> 20);
  if (!std::ifstream(path)) return "cannot be opened (permissions?)";
  return {};
}

Ini readIni(const std::filesystem::path& path) {
  Ini ini;
  ini.file = path.filename().string();
  std::ifstream in(path);
  std::string line, section;
  unsigned n = 0;
  while (std::getline(in, line)) {
    ++n;
    const auto t = trim(line);
    if (t.empty() || t[0] == '#' || t[0] == ';') continue;
    if (t[0] == '[') {
      section = t.substr(1, t.find(']') - 1);
      continue;
    }
    const auto eq = t.find('=');
    if (eq == std::string::npos) continue;
    ini.sections[section].emplace(trim(t.substr(0, eq)), IniEntry{trim(t.substr(eq + 1)), n});
  }
  return ini;
}

struct Reader {
  HalConfig& hal;
  std::vector<Finding>& findings;
  std::filesystem::path dir;  // where linuxcnc runs halcmd: the INI's folder
  unsigned depth = 0;         // files being read, one inside another (source)

  void error(const Where& w, std::string name, std::string reason, std::string suggestion = {},
             const char* severity = "error") {
    findings.push_back({w.file, w.line, severity, std::move(name), std::move(reason), std::move(suggestion)});
  }

  // [SECTION]KEY and [SECTION](KEY), as halcmd -i substitutes them. A scan,
  // one pass over the text: no regular expression, whose backtracking
  // recurses as deep as a long word is long.
  std::string substitute(const std::string& text, const Where& w) {
    auto word = [&](std::size_t from) {
      std::size_t i = from;
      while (i < text.size() && (std::isalnum(static_cast<unsigned char>(text[i])) != 0 || text[i] == '_')) ++i;
      return i;
    };
    std::string out;
    std::size_t last = 0;
    for (std::size_t at = text.find('['); at != std::string::npos; at = text.find('[', at + 1)) {
      if (at < last) continue;
      const std::size_t sectionEnd = word(at + 1);
      if (sectionEnd == at + 1 || sectionEnd >= text.size() || text[sectionEnd] != ']') continue;
      std::size_t keyFrom = sectionEnd + 1, keyEnd = 0, end = 0;
      if (keyFrom < text.size() && text[keyFrom] == '(') {
        keyEnd = word(keyFrom + 1);
        if (keyEnd > keyFrom + 1 && keyEnd < text.size() && text[keyEnd] == ')') {
          ++keyFrom;
          end = keyEnd + 1;
        }
      }
      if (end == 0) {  // not [S](K): [S]K
        keyFrom = sectionEnd + 1;
        keyEnd = word(keyFrom);
        if (keyEnd == keyFrom) continue;
        end = keyEnd;
      }
      const std::string match = text.substr(at, end - at);
      const std::string section = text.substr(at + 1, sectionEnd - at - 1);
      const std::string key = text.substr(keyFrom, keyEnd - keyFrom);
      out += text.substr(last, at - last);
      last = end;
      at = end - 1;
      if (!hal.hasIni) {
        error(w, match, fmt::format("{} needs an INI file (halcmd -i): check the .ini instead", match), {}, "warning");
        out += match;
        continue;
      }
      if (const auto* v = hal.ini.find(section, key)) {
        out += v->value;
      } else {
        error(w, match, fmt::format("the INI file has no [{}]{}: halcmd stops here", section, key));
        out += match;
      }
    }
    return out + text.substr(last);
  }

  // `text` as one [SECTION]KEY or [SECTION](KEY) and nothing else: its
  // section and key.
  static std::optional<std::pair<std::string, std::string>> wholeReference(const std::string& text) {
    auto isWord = [](char c) { return std::isalnum(static_cast<unsigned char>(c)) != 0 || c == '_'; };
    if (text.size() < 4 || text[0] != '[') return std::nullopt;
    const auto close = text.find(']');
    if (close == std::string::npos || close == 1) return std::nullopt;
    std::string section = text.substr(1, close - 1), key = text.substr(close + 1);
    if (key.size() >= 2 && key.front() == '(' && key.back() == ')') key = key.substr(1, key.size() - 2);
    if (key.empty() || !std::all_of(section.begin(), section.end(), isWord) || !std::all_of(key.begin(), key.end(), isWord))
      return std::nullopt;
    return std::make_pair(std::move(section), std::move(key));
  }

  static std::vector<std::string> tokens(const std::string& line) {
    std::vector<std::string> out;
    std::string cur;
    bool quoted = false, any = false;
    for (char c : line) {
      if (c == '"') {
        quoted = !quoted;
        any = true;
        continue;
      }
      if (!quoted && (c == ' ' || c == '\t')) {
        if (any) out.push_back(cur);
        cur.clear();
        any = false;
        continue;
      }
      cur += c;
      any = true;
    }
    if (any) out.push_back(cur);
    return out;
  }

  void readHal(const std::filesystem::path& path, const std::string& shown) {
    std::ifstream in(path);
    std::string raw, line;
    unsigned n = 0, start = 0;
    bool tooLong = false;  // the logical line being read is past kMaxLineBytes
    while (std::getline(in, raw)) {
      ++n;
      if (line.empty() && !tooLong) start = n;
      if (!raw.empty() && raw.back() == '\r') raw.pop_back();
      const bool continued = !raw.empty() && raw.back() == '\\';
      if (tooLong || line.size() + raw.size() > kMaxLineBytes) {
        if (!tooLong)
          error({shown, start}, {},
                fmt::format("a line of more than {} characters: not a HAL command, not read", kMaxLineBytes));
        tooLong = continued;
        line.clear();
        continue;
      }
      if (continued) {
        line += raw.substr(0, raw.size() - 1) + " ";
        continue;
      }
      line += raw;
      // A comment starts at a # that begins a word (halcmd(1)).
      bool quoted = false;
      for (std::size_t i = 0; i < line.size(); ++i) {
        if (line[i] == '"') quoted = !quoted;
        if (!quoted && line[i] == '#' && (i == 0 || line[i - 1] == ' ' || line[i - 1] == '\t')) {
          line.resize(i);
          break;
        }
      }
      const Where w{shown, start};
      statement(tokens(substitute(line, w)), tokens(line), w);
      line.clear();
    }
  }

  // `t`: the words after substitution; `written`: as written.
  void statement(const std::vector<std::string>& t, const std::vector<std::string>& written, const Where& w) {
    if (t.empty()) return;
    const auto& cmd = t[0];
    if (cmd == "loadrt" && t.size() >= 2 && t[1].rfind("hm2_", 0) == 0) {
      DriverLine d{t[1], {}, w, {}, {}, {}, w, false};
      for (std::size_t i = 2; i < t.size(); ++i)
        if (t[i].rfind("config=", 0) == 0)
          d.config = t[i].substr(7);
        else if (t[i].rfind("board_ip=", 0) == 0)
          d.boardIp = d.boardIps = t[i].substr(9);
      for (const auto& word : written)
        if (word.rfind("board_ip=", 0) == 0) {
          d.boardIpWritten = word.substr(9);
          d.boardIpFound = true;
          if (const auto ref = wholeReference(d.boardIpWritten)) {
            const auto* v = hal.hasIni ? hal.ini.find(ref->first, ref->second) : nullptr;
            if (v != nullptr) {
              // The INI's value whole (quotes aside), also what would
              // follow the address after a space.
              d.boardIpAt = {hal.ini.file, v->line};
              d.boardIps = v->value;
              if (d.boardIps.size() >= 2 && d.boardIps.front() == '"' && d.boardIps.back() == '"')
                d.boardIps = d.boardIps.substr(1, d.boardIps.size() - 2);
            } else
              d.boardIpFound = false;  // halcmd stops at it: reported by substitute()
          }
        }
      // One config per board, comma-separated (a module array parameter):
      // the first board's.
      if (const auto comma = d.config.find(','); comma != std::string::npos) d.config.resize(comma);
      if (const auto comma = d.boardIp.find(','); comma != std::string::npos) d.boardIp.resize(comma);
      hal.drivers.push_back(d);
    } else if (cmd == "loadrt" && t.size() >= 2) {
      hal.components.push_back({t[1], {t.begin() + 2, t.end()}, w});
    } else if (cmd == "net" && t.size() >= 2) {
      const auto& sig = t[1];
      hal.signalFirst.emplace(sig, w);
      for (std::size_t i = 2; i < t.size(); ++i) {
        if (t[i] == "=>" || t[i] == "<=" || t[i] == "<=>") continue;
        link(t[i], sig, w, Use::Net);
      }
    } else if (cmd == "setp" && t.size() >= 3) {
      hal.refs.push_back({w, t[1], Use::Setp, {}});
      hal.setps.push_back({w, t[1], t[2], written.size() >= 3 ? written[2] : t[2]});
    } else if (cmd == "sets" && t.size() >= 3) {
      hal.sets[t[1]].push_back(w);
      hal.signalSets.push_back({w, t[1], t[2], written.size() >= 3 ? written[2] : t[2]});
    } else if (cmd == "linkps" && t.size() >= 3) {
      hal.signalFirst.emplace(t[2], w);
      link(t[1], t[2], w, Use::Link);
    } else if (cmd == "linksp" && t.size() >= 3) {
      hal.signalFirst.emplace(t[1], w);
      link(t[2], t[1], w, Use::Link);
    } else if (cmd == "linkpp" && t.size() >= 3) {
      hal.signalFirst.emplace(t[1], w);
      link(t[1], t[1], w, Use::Link);
      link(t[2], t[1], w, Use::Link);
    } else if (cmd == "addf" && t.size() >= 3) {
      hal.refs.push_back({w, t[1], Use::Addf, {}});
    } else if (cmd == "source" && t.size() >= 2) {
      source(t[1], w);
    }
  }

  // halcmd's `source FILE`: FILE's commands, read where the command stands,
  // the path relative to halcmd's working folder (the INI's, as linuxcnc
  // runs it). A file that sources itself, directly or not, would never end:
  // halcmd keeps going until it runs out of file descriptors; here it is an
  // error at the line that goes too deep.
  void source(const std::string& name, const Where& w) {
    constexpr unsigned kMaxDepth = 16;
    const std::filesystem::path p = name;
    const auto full = p.is_absolute() ? p : dir / p;
    if (const auto why = unreadable(full); !why.empty()) {
      error(w, name, fmt::format("source {}: {}: halcmd stops here", name, why));
      return;
    }
    if (depth >= kMaxDepth) {
      error(w, name, fmt::format("source {}: files sourced {} deep (one sources itself?): not read", name, depth));
      return;
    }
    ++depth;
    readHal(full, p.string());
    --depth;
    hal.files.push_back(full.string());
  }

  void link(const std::string& pin, const std::string& sig, const Where& w, Use use) {
    hal.refs.push_back({w, pin, use, sig});
    auto& pins = hal.signals[sig];
    if (std::find(pins.begin(), pins.end(), pin) == pins.end()) pins.push_back(pin);
  }
};


}  // namespace

HalConfig readConfiguration(const std::filesystem::path& file, std::vector<Finding>& findings) {
  HalConfig hal;
  const auto dir = file.parent_path();
  Reader r{hal, findings, dir};
  if (const auto why = unreadable(file); !why.empty()) {
    findings.push_back({file.string(), 0, "error", {}, why, {}});
    return hal;
  }
  if (file.extension() == ".ini") {
    hal.ini = readIni(file);
    hal.hasIni = true;
    const Ini& ini = hal.ini;
    // [HAL]HALFILE in order, then POSTGUI_HALFILE and SHUTDOWN (LinuxCNC
    // runs them after the GUI is up and at exit).
    std::vector<std::pair<std::string, IniEntry>> halFiles;
    if (const auto s = ini.sections.find("HAL"); s != ini.sections.end()) {
      for (const char* key : {"HALFILE", "POSTGUI_HALFILE", "SHUTDOWN"}) {
        const auto range = s->second.equal_range(key);
        std::vector<IniEntry> entries;
        for (auto it = range.first; it != range.second; ++it) entries.push_back(it->second);
        std::sort(entries.begin(), entries.end(), [](const IniEntry& a, const IniEntry& b) { return a.line < b.line; });
        for (const auto& e : entries) halFiles.emplace_back(key, e);
      }
    }
    if (halFiles.empty())
      findings.push_back({file.filename().string(), 0, "warning", {}, "[HAL] names no HALFILE", {}});
    for (const auto& [key, e] : halFiles) {
      const auto words = Reader::tokens(e.value);
      if (words.empty()) continue;
      std::filesystem::path p = words[0];
      if (p.extension() == ".tcl") {
        findings.push_back({file.filename().string(), e.line, "warning", words[0],
                                   fmt::format("{} {}: Tcl HAL files are not checked", key, words[0]), {}});
        continue;
      }
      const auto full = p.is_absolute() ? p : dir / p;
      if (!std::filesystem::exists(full)) {
        // LinuxCNC also looks in its own HAL library (HALLIB_DIR).
        const auto lib = std::filesystem::path("/usr/share/linuxcnc/hallib") / p;
        if (!p.is_absolute() && std::filesystem::exists(lib)) {
          if (const auto why = unreadable(lib); !why.empty()) {
            findings.push_back({file.filename().string(), e.line, "error", words[0],
                                fmt::format("{} {}: {}: LinuxCNC cannot load it", key, lib.string(), why), {}});
            continue;
          }
          r.readHal(lib, lib.string());
          hal.files.push_back(lib.string());
          continue;
        }
        findings.push_back({file.filename().string(), e.line, "error", words[0],
                                   fmt::format("{} {}: no such file next to the INI (or in LinuxCNC's hallib)", key,
                                               words[0]),
                                   {}});
        continue;
      }
      if (const auto why = unreadable(full); !why.empty()) {
        findings.push_back({file.filename().string(), e.line, "error", words[0],
                            fmt::format("{} {}: {}: LinuxCNC cannot load it", key, words[0], why), {}});
        continue;
      }
      r.readHal(full, p.string());
      hal.files.push_back(full.string());
    }
  } else {
    r.readHal(file, file.filename().string());
    hal.files.push_back(file.string());
  }

  return hal;
}

}  // namespace lbpkit::linuxcnc
