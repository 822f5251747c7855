// SPDX-License-Identifier: MIT
// Reading lbpkit's TOML files (the sim's card configuration, machine files)
// so that every mistake is an error naming the file, line, column and key:
// a misspelt key that was silently ignored, or a value silently replaced by a
// default, would leave the user testing a machine they did not describe.
#pragma once

#include <cstdint>
#include <initializer_list>
#include <stdexcept>
#include <string>
#include <string_view>
#include <toml++/toml.h>
#include <utility>

namespace lbpkit::config {

// A mistake in a file, or a file that cannot be read: "FILE:LINE:COL: key:
// what" (or "FILE: what" when there is no place in the file to point at).
class FileError : public std::runtime_error {
 public:
  // Control characters from the file (a NUL in a string would end the
  // message where it is printed as a C string) show as \xNN.
  explicit FileError(const std::string& what) : std::runtime_error(printable(what)) {}

 private:
  static std::string printable(const std::string& text) {
    static constexpr char kHex[] = "0123456789abcdef";
    std::string out;
    out.reserve(text.size());
    for (const char c : text) {
      const auto u = static_cast<unsigned char>(c);
      if ((u < 0x20 && c != '\n' && c != '\t') || u == 0x7F) {
        out += "\\x";
        out += kHex[u >> 4];
        out += kHex[u & 0xF];
      } else {
        out += c;
      }
    }
    return out;
  }
};

// The file at `path`, parsed. `what` says what kind of file was expected,
// for the error when `path` is a directory or a device ("a TOML
// configuration file").
[[nodiscard]] toml::table parseFile(const std::string& path, std::string_view what);

class ConfigReader {
 public:
  explicit ConfigReader(std::string path) : path_(std::move(path)) {}

  // Throws FileError "FILE:LINE:COL: key: what" with the place of `node`
  // (or "FILE: key: what" without one).
  [[noreturn]] void fail(const toml::node* node, const std::string& key, const std::string& what) const;

  // Refuses keys the table may not have, suggesting the nearest known one.
  void onlyKeys(const toml::table& t, const std::string& prefix, std::initializer_list<std::string_view> known) const;

  // A number (an integer is taken too) in [min, max], `unit` for the error
  // messages; `fallback` when the key is absent.
  [[nodiscard]] double number(const toml::table& t, const std::string& prefix, std::string_view key, double fallback,
                              double min, double max, std::string_view unit) const;
  // The same for a quantity that must be above 0 (masses, pitches, gains):
  // `min`, above 0, is the smallest a real machine has, so that a value such
  // as 1e-308 is refused instead of dividing by next to nothing later.
  [[nodiscard]] double positive(const toml::table& t, const std::string& prefix, std::string_view key,
                                double fallback, double min, double max, std::string_view unit) const;

  // [low, high] with low < high, both in [min, max]: a range of travel.
  [[nodiscard]] std::pair<double, double> interval(const toml::table& t, const std::string& prefix,
                                                   std::string_view key, std::pair<double, double> fallback,
                                                   double min, double max, std::string_view unit) const;

  // How integers show in range errors: unit numbers read best in hex.
  enum class Radix { Decimal, Hex };
  [[nodiscard]] std::int64_t integer(const toml::table& t, const std::string& prefix, std::string_view key,
                                     std::int64_t fallback, std::int64_t min, std::int64_t max,
                                     Radix radix = Radix::Decimal) const;

  [[nodiscard]] bool boolean(const toml::table& t, const std::string& prefix, std::string_view key,
                             bool fallback) const;

  // A string, one of `allowed`.
  [[nodiscard]] std::string text(const toml::table& t, const std::string& prefix, std::string_view key,
                                 std::string fallback, std::initializer_list<std::string_view> allowed) const;
  // A name: non-empty, letters, digits, '_' and '-' only (names end up in
  // HAL-like identifiers, CSV columns and URLs).
  [[nodiscard]] std::string name(const toml::table& t, const std::string& prefix, std::string_view key,
                                 std::string fallback) const;

  // A key that must be there: the node, or an error pointing at the table.
  [[nodiscard]] const toml::node& required(const toml::table& t, const std::string& prefix,
                                           std::string_view key) const;
  // [name] (nullptr when absent) and [[name]] (nullptr when absent), checked
  // to be what they say.
  [[nodiscard]] const toml::table* table(const toml::table& t, const std::string& prefix, std::string_view key) const;
  [[nodiscard]] const toml::array* tables(const toml::table& t, const std::string& prefix, std::string_view key) const;
  // Element i of an array of tables (an error if it is not a table).
  [[nodiscard]] const toml::table& element(const toml::array& a, const std::string& name, std::size_t i) const;

  [[nodiscard]] const std::string& path() const { return path_; }
  // "LINE:COL" of a node, for messages that point at a second place.
  [[nodiscard]] static std::string where(const toml::node* node);
  [[nodiscard]] static std::string typeName(const toml::node& n);

 private:
  [[nodiscard]] double numberValue(const toml::node& n, const std::string& name, std::string_view unit) const;
  std::string path_;
};

}  // namespace lbpkit::config
