// SPDX-License-Identifier: MIT
// halcmd(1): INI substitution, comments, continued lines, quoting; the
// INI's [HAL] section (LinuxCNC's INI documentation).
#include "linuxcnc/hal_config.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cctype>
#include <cstdlib>
#include <fstream>
#include <string_view>
#include <optional>
#include <set>
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

// Each line of `path` (without its newline) to `line`, with whether a
// newline ends it, reading at most `limit` bytes. False when the file holds
// more (the rest is not read). Reads in blocks, so a file that says it is
// empty and never ends (under /proc) costs no more than `limit`.
bool forEachLine(const std::filesystem::path& path, std::uintmax_t limit,
                 const std::function<void(const std::string&, bool newline)>& line) {
  std::ifstream in(path, std::ios::binary);
  std::string current;
  std::vector<char> block(64U << 10);
  std::uintmax_t total = 0;
  while (in) {
    in.read(block.data(), static_cast<std::streamsize>(block.size()));
    const auto got = static_cast<std::size_t>(in.gcount());
    if (got == 0) break;
    total += got;
    const bool over = total > limit;
    const std::size_t use = over ? got - static_cast<std::size_t>(total - limit) : got;
    std::size_t from = 0;
    for (std::size_t i = 0; i < use; ++i)
      if (block[i] == '\n') {
        current.append(block.data() + from, i - from);
        line(current, true);
        current.clear();
        from = i + 1;
      }
    current.append(block.data() + from, use - from);
    if (over) return false;
  }
  if (!current.empty()) line(current, false);
  return true;
}

// An #INCLUDE's file name as the `linuxcnc` script expands it (the shell's
// `eval echo NAME`), for the names lbpkit can expand as the shell would:
// plain words (joined by one space), `~` or `~/...` at a word's start ($HOME),
// $NAME and ${NAME} from the environment, a word starting with # ending the
// name. Anything else (quotes, backslashes, globs, command substitution, ~user,
// ...) sets `why` and gives "".
std::string shellName(const std::string& text, std::string& why) {
  auto plain = [](char c) {
    return std::isalnum(static_cast<unsigned char>(c)) != 0 || std::string_view("/._-+,=@%:^").find(c) != std::string_view::npos;
  };
  auto variable = [&](const std::string& name, std::string& out) {
    const char* v = std::getenv(name.c_str());
    const std::string value = v == nullptr ? std::string() : v;
    if (value.find_first_of(" \t\n*?[") != std::string::npos) {
      why = fmt::format("${} is \"{}\", which the shell would split or expand as a pattern", name, value);
      return false;
    }
    out += value;
    return true;
  };
  std::vector<std::string> words;
  std::size_t i = 0;
  while (i < text.size()) {
    while (i < text.size() && (text[i] == ' ' || text[i] == '\t')) ++i;
    if (i >= text.size() || text[i] == '#') break;  // the shell's comment
    std::string word;
    const std::size_t start = i;
    for (; i < text.size() && text[i] != ' ' && text[i] != '\t'; ++i) {
      const char c = text[i];
      if (plain(c)) {
        word += c;
      } else if (c == '~' && i == start && (i + 1 == text.size() || text[i + 1] == '/' || text[i + 1] == ' ' ||
                                            text[i + 1] == '\t')) {
        const char* home = std::getenv("HOME");
        if (home == nullptr) {
          why = "~ with no HOME in the environment";
          return {};
        }
        if (!variable("HOME", word)) return {};
      } else if (c == '$') {
        std::size_t from = i + 1, to = from;
        const bool braced = from < text.size() && text[from] == '{';
        if (braced) ++from, to = from;
        if (to < text.size() && (std::isalpha(static_cast<unsigned char>(text[to])) != 0 || text[to] == '_'))
          while (to < text.size() && (std::isalnum(static_cast<unsigned char>(text[to])) != 0 || text[to] == '_')) ++to;
        if (to == from || (braced && (to >= text.size() || text[to] != '}'))) {
          why = fmt::format("\"{}\" is more than $NAME or ${{NAME}} (lbpkit expands only those)", text.substr(i));
          return {};
        }
        if (!variable(text.substr(from, to - from), word)) return {};
        i = braced ? to : to - 1;
      } else {
        why = c == '\r' ? std::string("the line ends in a carriage return (a DOS line end), which the shell keeps in "
                                      "the name")
                        : fmt::format("'{}' in the name: lbpkit expands plain names, ~ and $VARIABLE, not what else "
                                      "the shell does with it",
                                      c);
        return {};
      }
    }
    if (words.empty() && word.starts_with("-")) {
      why = fmt::format("\"{}\" would be an option of echo", word);
      return {};
    }
    words.push_back(std::move(word));
  }
  std::string out;
  for (const auto& w : words) out += (out.empty() ? "" : " ") + w;
  return out;
}

// One line of the INI as the shell's `read FIRST REST` gives it (no -r):
// backslash escapes taken out, the white space around the line and after
// its first word dropped; the two words apart.
std::pair<std::string, std::string> readWords(const std::string& line) {
  std::string first, rest;
  std::size_t i = 0;
  auto ws = [](char c) { return c == ' ' || c == '\t'; };
  while (i < line.size() && ws(line[i])) ++i;
  for (; i < line.size() && !ws(line[i]); ++i) {
    if (line[i] == '\\' && i + 1 < line.size()) ++i;
    if (line[i] != '\0') first += line[i];
  }
  while (i < line.size() && ws(line[i])) ++i;
  std::size_t keep = 0;  // rest's length without white space at its end
  for (; i < line.size(); ++i) {
    const bool escaped = line[i] == '\\' && i + 1 < line.size();
    if (escaped) ++i;
    if (line[i] == '\0') continue;
    rest += line[i];
    if (escaped || !ws(line[i])) keep = rest.size();
  }
  rest.resize(keep);
  return {first, rest};
}

}  // namespace

void readIniLines(const std::filesystem::path& ini, const std::string& shownAs, std::vector<Finding>* findings,
                  const std::function<void(const std::string& text, const std::string& file, unsigned line)>& line) {
  auto say = [&](const std::string& file, unsigned at, const char* severity, std::string name, std::string reason) {
    if (findings != nullptr) findings->push_back({file, at, severity, std::move(name), std::move(reason), {}});
  };
  // `linuxcnc` expands #INCLUDE only in an INI with a line that starts with it.
  bool expand = false;
  forEachLine(ini, kMaxFileBytes, [&](const std::string& l, bool) { expand = expand || l.starts_with("#INCLUDE"); });
  if (!expand) {
    unsigned n = 0;
    forEachLine(ini, kMaxFileBytes, [&](const std::string& l, bool) {
      ++n;
      const auto t = trim(l);
      if (t.starts_with("#INCLUDE") && (t.size() == 8 || t[8] == ' ' || t[8] == '\t'))
        say(shownAs, n, "warning", "#INCLUDE",
            fmt::format("{}: linuxcnc expands #INCLUDE only in an INI with a line that starts with it (this one is "
                        "indented), so here it is a comment and nothing is included",
                        t));
      line(l, shownAs, n);
    });
    return;
  }
  const auto dir = ini.parent_path();
  std::uintmax_t included = 0;  // bytes read from included files
  unsigned pastBound = 0;      // #INCLUDEs past that bound, not read
  std::string pending, section;
  unsigned n = 0, first = 0;
  auto deliver = [&](const std::string& text, const std::string& file, unsigned at) {
    if (const auto t = trim(text); t.starts_with("[") && t.find(']') != std::string::npos)
      section = t.substr(1, t.find(']') - 1);
    line(text, file, at);
  };
  auto include = [&](const std::string& written, unsigned at) {
    const std::string under = section.empty() ? std::string() : fmt::format(" (here, under [{}])", section);
    if (written.empty()) {
      say(shownAs, at, "warning", "#INCLUDE",
          "#INCLUDE names no file: linuxcnc says so and goes on (nothing is included)");
      return;
    }
    std::string why;
    const std::string name = shellName(written, why);
    if (!why.empty()) {
      say(shownAs, at, "error", "#INCLUDE",
          fmt::format("#INCLUDE {}: {}; lbpkit does not read the file, so whatever it holds{} is not checked",
                      written, why, under));
      return;
    }
    const std::filesystem::path p = name;
    const auto full = p.is_absolute() ? p : dir / p;
    if (name.empty()) why = "no file name once the shell expands it";
    if (why.empty()) why = unreadable(full);
    if (why.empty() && std::filesystem::file_size(full) > kMaxFileBytes - included) {
      if (pastBound++ == 0)
        say(shownAs, at, "error", "#INCLUDE",
            fmt::format("#INCLUDE {}: the files the INI includes come to more than the {} MiB lbpkit reads: this one "
                        "and any after it that do not fit are not read, so what they hold is not checked",
                        written, kMaxFileBytes >> 20));
      return;
    }
    if (!why.empty()) {
      say(shownAs, at, "error", "#INCLUDE",
          fmt::format("#INCLUDE {}: {}: linuxcnc reports it and starts without that file, so whatever it holds{} is "
                      "missing from the INI",
                      written, why, under));
      return;
    }
    unsigned k = 0;
    std::string last;
    bool ended = true;
    const bool read = forEachLine(full, kMaxFileBytes - included, [&](const std::string& l, bool newline) {
      ++k;
      included += l.size() + (newline ? 1 : 0);
      const auto [word, rest] = readWords(l);
      if (word == "#INCLUDE")
        say(name, k, "warning", "#INCLUDE",
            fmt::format("#INCLUDE {} in a file the INI includes: linuxcnc expands one level, so this line is a comment "
                        "and nothing is included",
                        rest));
      if (!newline) {
        // `cat` copies the file as it is: linuxcnc's own end-of-include
        // comment line then goes on this last line.
        ended = false;
        last = l;
        return;
      }
      deliver(l, name, k);
    });
    if (!read)
      say(shownAs, at, "error", "#INCLUDE",
          fmt::format("#INCLUDE {}: the files the INI includes come to more than the {} MiB lbpkit reads: the rest of "
                      "{} is not read",
                      written, kMaxFileBytes >> 20, name));
    if (!ended) {
      say(name, k, "warning", {},
          fmt::format("the last line of {} has no newline: linuxcnc's #INCLUDE writes its end-of-file comment onto it, "
                      "so LinuxCNC reads \"{}#...\"",
                      name, trim(last)));
      deliver(last + "#(the end of an #INCLUDE)", name, k);
    }
  };
  const bool whole = forEachLine(ini, kMaxFileBytes, [&](const std::string& raw, bool newline) {
    ++n;
    if (pending.empty()) first = n;
    // A backslash at the end of a line joins the next to it.
    bool joined = false;
    for (std::size_t i = 0; i < raw.size(); ++i) {
      if (raw[i] != '\\') continue;
      if (i + 1 == raw.size()) joined = true;
      ++i;
    }
    pending += joined ? raw.substr(0, raw.size() - 1) : raw;
    if (joined && newline) return;
    if (!newline) {
      // `read` gives up on a line with no newline: linuxcnc leaves it out.
      if (!trim(pending).empty())
        say(shownAs, first, "warning", {},
            fmt::format("the INI's last line has no newline, and linuxcnc's #INCLUDE expansion leaves it out: "
                        "LinuxCNC never reads \"{}\"",
                        trim(pending)));
      pending.clear();
      return;
    }
    const auto [word, rest] = readWords(pending);
    pending.clear();
    if (word == "#INCLUDE") {
      include(rest, first);
      return;
    }
    deliver(word + " " + rest, shownAs, first);
  });
  if (pastBound > 1)
    say(shownAs, 0, "error", "#INCLUDE",
        fmt::format("{} #INCLUDEs past the {} MiB lbpkit reads of included files: not read", pastBound,
                    kMaxFileBytes >> 20));
  if (!whole)
    say(shownAs, n, "error", {},
        fmt::format("the INI is longer than the {} MiB lbpkit reads: the rest is not read", kMaxFileBytes >> 20));
}

namespace {

Ini readIni(const std::filesystem::path& path, std::vector<Finding>& findings) {
  Ini ini;
  ini.file = path.filename().string();
  std::string section;
  readIniLines(path, ini.file, &findings, [&](const std::string& line, const std::string& file, unsigned n) {
    const auto t = trim(line);
    if (t.empty() || t[0] == '#' || t[0] == ';') return;
    if (t[0] == '[') {
      section = t.substr(1, t.find(']') - 1);
      ini.sectionAt.try_emplace(section, Where{file, n});
      return;
    }
    const auto eq = t.find('=');
    if (eq == std::string::npos) return;
    ini.sections[section].emplace(trim(t.substr(0, eq)), IniEntry{trim(t.substr(eq + 1)), n, file});
  });
  return ini;
}

struct Reader {
  HalConfig& hal;
  std::vector<Finding>& findings;
  std::filesystem::path dir;  // where linuxcnc runs halcmd: the INI's folder
  unsigned depth = 0;         // files being read, one inside another (source)
  bool twopass = false;       // [HAL]TWOPASS: haltcl runs the HAL files as Tcl

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
    ++hal.commands;
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
              d.boardIpAt = {v->file, v->line};
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
  void source(const std::string& name, const Where& w, bool tcl = false) {
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
    // With [HAL]TWOPASS, haltcl runs the HAL files as Tcl, and their
    // `source` reads a Tcl file (LinuxCNC: lib/hallib/twopass.tcl).
    if (tcl || (twopass && p.extension() == ".tcl"))
      readTcl(full, p.string());
    else
      readHal(full, p.string());
    --depth;
    hal.files.push_back(full.string());
  }

  // A Tcl HAL file (a HALFILE ending in .tcl, which haltcl runs, and what a
  // Tcl file sources), read as far as lbpkit can: its HAL commands (loadrt,
  // net, setp, ..., also after `hal`) with the INI's values as haltcl gives
  // them: $::SECTION(KEY) (every value of KEY, in order, as a Tcl list),
  // $SECTION(KEY), [lindex $::SECTION(KEY) N]. Other Tcl (set, if, proc,
  // other substitutions) lbpkit does not read: a warning names the file, how
  // many commands that leaves out and the first of them.
  void readTcl(const std::filesystem::path& path, const std::string& shown) {
    std::ifstream in(path);
    std::string raw, text;
    unsigned n = 0, start = 0, skipped = 0;
    Where firstSkipped;
    std::string firstSkippedText;
    int depthNow = 0;
    bool quoted = false;
    auto command = [&](const std::string& cmd, const Where& w) {
      const auto t = trim(cmd);
      if (t.empty() || t[0] == '#') return;
      if (!tclCommand(t, w)) {
        if (skipped++ == 0) {
          firstSkipped = w;
          firstSkippedText = t.substr(0, std::min<std::size_t>(t.find('\n'), 60));
        }
      }
    };
    // The commands of `text`: split at ; and newlines outside braces,
    // brackets and quotes.
    auto flush = [&] {
      if (text.empty()) return;
      int d = 0;
      bool q = false;
      std::size_t from = 0;
      unsigned at = start;
      for (std::size_t i = 0; i <= text.size(); ++i) {
        const char c = i < text.size() ? text[i] : ';';
        if (c == '\\' && i + 1 < text.size()) {
          ++i;
          continue;
        }
        if (c == '"' && d == 0) q = !q;
        if (!q && (c == '{' || c == '[')) ++d;
        if (!q && (c == '}' || c == ']')) --d;
        if ((c == ';' || c == '\n') && d <= 0 && !q) {
          const auto cmd = text.substr(from, i - from);
          // A # starts a comment where a command would start: to the line's end.
          if (const auto t = trim(cmd); c == ';' && t.starts_with("#")) {
            const auto eol = text.find('\n', i);
            i = eol == std::string::npos ? text.size() : eol;
          }
          command(text.substr(from, i - from), {shown, at});
          for (std::size_t k = from; k < i && k < text.size(); ++k)
            if (text[k] == '\n') ++at;
          if (i < text.size() && text[i] == '\n') ++at;
          from = i + 1;
        }
      }
      text.clear();
      depthNow = 0;
      quoted = false;
    };
    while (std::getline(in, raw)) {
      ++n;
      if (text.empty()) start = n;
      if (!raw.empty() && raw.back() == '\r') raw.pop_back();
      if (text.size() + raw.size() > kMaxLineBytes) {
        error({shown, start}, {},
              fmt::format("a Tcl command of more than {} characters: not read", kMaxLineBytes));
        text.clear();
        depthNow = 0;
        quoted = false;
        continue;
      }
      // A backslash at the end continues the line; braces, brackets and
      // quotes left open continue the command.
      bool continued = false;
      for (std::size_t i = 0; i < raw.size(); ++i) {
        const char c = raw[i];
        if (c == '\\') {
          if (i + 1 == raw.size()) continued = true;
          ++i;
        } else if (c == '"' && depthNow == 0) {
          quoted = !quoted;
        } else if (!quoted && (c == '{' || c == '[')) {
          ++depthNow;
        } else if (!quoted && (c == '}' || c == ']')) {
          --depthNow;
        }
      }
      text += continued ? raw.substr(0, raw.size() - 1) + " " : raw;
      if (continued || ((depthNow > 0 || quoted) && !in.eof())) {
        if (!continued) text += '\n';
        continue;
      }
      flush();
    }
    flush();  // a last line continued by a backslash
    if (skipped > 0)
      error(firstSkipped, {},
            fmt::format("{}: {} Tcl command{} lbpkit does not read (it reads a Tcl HAL file's HAL commands with the "
                        "INI's values, not other Tcl), the first \"{}\": what {} is not checked",
                        shown, skipped, skipped == 1 ? "" : "s", firstSkippedText, skipped == 1 ? "it does" : "they do"),
            {}, "warning");
  }

  // One Tcl command: read when it is a HAL command whose words lbpkit can
  // substitute; false when it is not.
  bool tclCommand(const std::string& cmd, const Where& w) {
    static const std::set<std::string> halCommands = {
        "loadrt", "loadusr", "waitusr", "unload",  "net",    "linkps", "linksp", "linkpp", "unlinkp",
        "newsig", "delsig",  "setp",    "sets",    "addf",   "delf",   "start",  "stop",   "show",
        "alias",  "unalias", "lock",    "unlock",  "ptype",  "stype",  "getp",   "echo",   "unecho",
        "save",   "status",  "source"};
    std::vector<std::string> words, written;
    std::size_t i = 0;
    while (true) {
      while (i < cmd.size() && std::isspace(static_cast<unsigned char>(cmd[i])) != 0) ++i;
      if (i >= cmd.size()) break;
      std::string word, as;
      if (cmd[i] == '{') {  // no substitution in braces
        int d = 0;
        std::size_t j = i;
        for (; j < cmd.size(); ++j) {
          if (cmd[j] == '{') ++d;
          if (cmd[j] == '}' && --d == 0) break;
        }
        if (j >= cmd.size()) return false;
        word = as = cmd.substr(i + 1, j - i - 1);
        i = j + 1;
      } else {
        const bool inQuotes = cmd[i] == '"';
        if (inQuotes) ++i;
        for (; i < cmd.size(); ++i) {
          const char c = cmd[i];
          if (inQuotes ? c == '"' : std::isspace(static_cast<unsigned char>(c)) != 0) break;
          if (c == '\\') return false;
          if (c == '$' || c == '[') {
            std::string section, key;
            std::size_t end = 0, index = 0;
            if (!tclIniReference(cmd, i, section, key, index, end)) return false;
            std::vector<std::string> values;
            if (const auto sec = hal.ini.sections.find(section); hal.hasIni && sec != hal.ini.sections.end())
              for (auto [a, b] = sec->second.equal_range(key); a != b; ++a) values.push_back(a->second.value);
            if (values.empty()) {
              error(w, fmt::format("[{}]{}", section, key),
                    fmt::format("the INI has no [{}]{}: haltcl stops here (a Tcl error)", section, key));
              return true;
            }
            if (index == std::string::npos) {
              for (const auto& v : values) word += (&v == &values.front() ? "" : " ") + v;
            } else if (index < values.size()) {
              word += values[index];
            }
            as += fmt::format("[{}]{}", section, key);
            i = end - 1;
            continue;
          }
          word += c;
          as += c;
        }
        if (inQuotes) {
          if (i >= cmd.size()) return false;
          ++i;
        }
      }
      // A module argument KEY="VALUE": rtapi takes the quotes away.
      if (const auto eq = word.find('='); eq != std::string::npos && word.size() >= eq + 3 && word[eq + 1] == '"' &&
                                          word.back() == '"')
        word = word.substr(0, eq + 1) + word.substr(eq + 2, word.size() - eq - 3);
      words.push_back(std::move(word));
      written.push_back(std::move(as));
    }
    if (!words.empty() && words[0] == "hal") {
      words.erase(words.begin());
      written.erase(written.begin());
    }
    if (words.empty() || !halCommands.count(words[0])) return false;
    if (words[0] == "source") {
      if (words.size() >= 2) source(words[1], w, true);
      return true;
    }
    statement(words, written, w);
    return true;
  }

  // $::SECTION(KEY), $SECTION(KEY) or [lindex $::SECTION(KEY) N] at
  // cmd[at]: its section, key, N (npos for the whole list) and where it
  // ends.
  static bool tclIniReference(const std::string& cmd, std::size_t at, std::string& section, std::string& key,
                              std::size_t& index, std::size_t& end) {
    auto isWord = [](char c) { return std::isalnum(static_cast<unsigned char>(c)) != 0 || c == '_'; };
    auto variable = [&](std::size_t i) -> std::size_t {  // at '$': where it ends, or 0
      if (i >= cmd.size() || cmd[i] != '$') return 0;
      ++i;
      if (cmd.compare(i, 2, "::") == 0) i += 2;
      const std::size_t s = i;
      while (i < cmd.size() && isWord(cmd[i])) ++i;
      if (i == s || i >= cmd.size() || cmd[i] != '(') return 0;
      section = cmd.substr(s, i - s);
      const std::size_t k = ++i;
      while (i < cmd.size() && cmd[i] != ')' && isWord(cmd[i])) ++i;
      if (i == k || i >= cmd.size() || cmd[i] != ')') return 0;
      key = cmd.substr(k, i - k);
      return i + 1;
    };
    index = std::string::npos;
    if (cmd[at] == '$') {
      end = variable(at);
      return end != 0;
    }
    // [lindex $::S(K) N]
    std::size_t i = at + 1;
    while (i < cmd.size() && cmd[i] == ' ') ++i;
    if (cmd.compare(i, 7, "lindex ") != 0) return false;
    i += 7;
    while (i < cmd.size() && cmd[i] == ' ') ++i;
    i = variable(i);
    if (i == 0) return false;
    while (i < cmd.size() && cmd[i] == ' ') ++i;
    const std::size_t d = i;
    while (i < cmd.size() && std::isdigit(static_cast<unsigned char>(cmd[i])) != 0) ++i;
    if (i == d || i - d > 6) return false;
    index = std::stoul(cmd.substr(d, i - d));
    while (i < cmd.size() && cmd[i] == ' ') ++i;
    if (i >= cmd.size() || cmd[i] != ']') return false;
    end = i + 1;
    return true;
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
    hal.ini = readIni(file, findings);
    hal.hasIni = true;
    const Ini& ini = hal.ini;
    // [HAL]HALFILE in order, then POSTGUI_HALFILE and SHUTDOWN (LinuxCNC
    // runs them after the GUI is up and at exit).
    std::vector<std::pair<std::string, IniEntry>> halFiles;
    if (const auto s = ini.sections.find("HAL"); s != ini.sections.end()) {
      for (const char* key : {"HALFILE", "POSTGUI_HALFILE", "SHUTDOWN"}) {
        const auto range = s->second.equal_range(key);
        // In the order the (expanded) INI gives them: a multimap keeps
        // equal keys in the order they were added.
        for (auto it = range.first; it != range.second; ++it) halFiles.emplace_back(key, it->second);
      }
    }
    if (halFiles.empty())
      findings.push_back({file.filename().string(), 0, "warning", {}, "[HAL] names no HALFILE", {}});
    hal.halFilesNamed = static_cast<unsigned>(halFiles.size());
    if (const auto* t = ini.find("HAL", "TWOPASS"); t != nullptr && !t->value.empty()) r.twopass = true;
    for (const auto& [key, e] : halFiles) {
      const auto words = Reader::tokens(e.value);
      if (words.empty()) continue;
      std::filesystem::path p = words[0];
      auto full = p.is_absolute() ? p : dir / p;
      std::string shown = p.string();
      if (!std::filesystem::exists(full)) {
        // LinuxCNC also looks in its own HAL library (HALLIB_DIR).
        const auto lib = std::filesystem::path("/usr/share/linuxcnc/hallib") / p;
        if (p.is_absolute() || !std::filesystem::exists(lib)) {
          findings.push_back({e.file, e.line, "error", words[0],
                              fmt::format("{} {}: no such file next to the INI (or in LinuxCNC's hallib)", key,
                                          words[0]),
                              {}});
          continue;
        }
        full = lib;
        shown = lib.string();
      }
      if (const auto why = unreadable(full); !why.empty()) {
        findings.push_back({e.file, e.line, "error", words[0],
                            fmt::format("{} {}: {}: LinuxCNC cannot load it", key, shown, why), {}});
        continue;
      }
      // A .tcl file LinuxCNC runs with haltcl; any other with halcmd, or
      // with haltcl as Tcl under [HAL]TWOPASS (LinuxCNC: lib/hallib/twopass.tcl).
      if (p.extension() == ".tcl")
        r.readTcl(full, shown);
      else
        r.readHal(full, shown);
      hal.files.push_back(full.string());
    }
  } else {
    r.readHal(file, file.filename().string());
    hal.files.push_back(file.string());
  }

  return hal;
}

}  // namespace lbpkit::linuxcnc
