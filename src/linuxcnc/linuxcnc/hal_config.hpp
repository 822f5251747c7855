// SPDX-License-Identifier: MIT
// A LinuxCNC configuration read as LinuxCNC reads it (halcmd(1), the INI
// file's [HAL] section): the INI's values, and every HAL file it names
// with [SECTION]KEY substituted, as the statements that matter to what a
// configuration connects: loadrt (the hostmot2 drivers and the other
// components), net, setp, sets, link*, addf. What `lbpkit check-config`
// checks and `lbpkit machine --from-config` derives a machine from. Needs no
// LinuxCNC.
#pragma once

#include <filesystem>
#include <functional>
#include <map>
#include <string>
#include <vector>

namespace lbpkit::linuxcnc {

// Something said about a configuration: where, how bad, about what.
struct Finding {
  std::string file;  // as given (relative to the INI's folder for HAL files)
  unsigned line = 0;
  std::string severity;  // "error" or "warning"
  std::string name;      // the pin, parameter or signal it is about ("" for others)
  std::string reason;
  std::string suggestion;  // the nearest existing name, if any
};

struct Where {
  std::string file;
  unsigned line = 0;
};

// A KEY = VALUE of the INI: its value and where it is written (the INI, or
// a file the INI pulls in with #INCLUDE, and that file's line).
struct IniEntry {
  std::string value;
  unsigned line = 0;
  std::string file;
};

struct Ini {
  std::string file;  // its name, as findings give it
  std::map<std::string, std::multimap<std::string, IniEntry>> sections;
  std::map<std::string, Where> sectionAt;  // where each [SECTION] is first opened
  // The first KEY in [SECTION], or nullptr.
  [[nodiscard]] const IniEntry* find(const std::string& section, const std::string& key) const;
};

enum class Use { Net, Setp, Link, Addf };

// A pin, parameter or function named by a statement.
struct Reference {
  Where at;
  std::string name;
  Use use = Use::Net;
  std::string signal;  // for Net/Link
};

// loadrt of a hostmot2 driver (hm2_eth, hm2_pci, ...).
struct DriverLine {
  std::string module;
  std::string config;  // the first board's config= string
  Where at;
  std::string boardIp;  // the first board's board_ip=
  // board_ip= whole, one address per board (comma-separated), after
  // substitution (when it is one [SECTION]KEY the INI has: the INI's value
  // whole, quotes aside); as written ("[HM2]IPADDRESS"); and where its value
  // is written: that INI line, else this line. boardIpFound is false when there is no board_ip= and when its
  // [SECTION]KEY is not in the INI (reported as such).
  std::string boardIps;
  std::string boardIpWritten;
  Where boardIpAt;
  bool boardIpFound = false;
};

// loadrt of any other component, with its arguments (names=, count=).
struct LoadedComponent {
  std::string module;
  std::vector<std::string> arguments;
  Where at;
};

// setp NAME VALUE: the value after substitution, and as written
// ("[JOINT_0]ENCODER_SCALE").
struct Setp {
  Where at;
  std::string name;
  std::string value;
  std::string written;
};

struct HalConfig {
  bool hasIni = false;
  Ini ini;
  std::vector<Reference> refs;
  std::vector<DriverLine> drivers;
  std::vector<LoadedComponent> components;
  std::vector<Setp> setps;
  std::map<std::string, std::vector<Where>> sets;           // signal -> sets lines
  std::vector<Setp> signalSets;  // sets SIGNAL VALUE, in order: name is the signal
  std::map<std::string, std::vector<std::string>> signals;  // signal -> pins, in order
  std::map<std::string, Where> signalFirst;
  std::vector<std::string> files;  // the HAL files read
  // HAL files the INI names ([HAL]HALFILE, POSTGUI_HALFILE, SHUTDOWN), read
  // or not.
  unsigned halFilesNamed = 0;
  unsigned commands = 0;  // HAL commands read in them (halcmd's, or a Tcl file's)

  // The signal `pin` is on ("" when none), and the last setp of `name`
  // (nullptr when none).
  [[nodiscard]] std::string signalOf(const std::string& pin) const;
  [[nodiscard]] const Setp* setpOf(const std::string& name) const;
};

// Reads an INI and the HAL files its [HAL] section names, in LinuxCNC's
// order (HALFILE, then POSTGUI_HALFILE, then SHUTDOWN), or one HAL file.
// What LinuxCNC would refuse on the way (a missing file, an unknown
// [SECTION]KEY) goes to `findings`.
HalConfig readConfiguration(const std::filesystem::path& file, std::vector<Finding>& findings);

// The lines of the INI `ini` as everything in LinuxCNC reads them: after the
// `linuxcnc` command's #INCLUDE expansion (LinuxCNC: scripts/linuxcnc.in,
// handle_includes), each handed to `line` with the file it is written in
// (`shownAs` for the INI itself, an included file by its name as the INI
// gives it) and its line there. What LinuxCNC reports on the way (an
// #INCLUDE of a file it cannot read, ...) goes to `findings` when given.
// At most 16 MiB are read from each file, and from all included files
// together. docs/check-config.md#include-and-tcl-hal-files
void readIniLines(const std::filesystem::path& ini, const std::string& shownAs, std::vector<Finding>* findings,
                  const std::function<void(const std::string& text, const std::string& file, unsigned line)>& line);

std::string trim(const std::string& s);

}  // namespace lbpkit::linuxcnc
