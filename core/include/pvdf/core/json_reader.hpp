// Strict reading of JSON input files: every key is known, typed, finite and in range, and
// every complaint names the file, the key path, the value, the rule and the fix.
#pragma once

#include <nlohmann/json.hpp>

#include <array>
#include <optional>
#include <set>
#include <string>
#include <vector>

namespace pvdf {

/// A view of one JSON object inside a file, with its key path (`membrane.radius_m`,
/// `electrodes[2].size_m`). Reading a key marks it as used; `finish()` rejects any key that
/// was never read, so a typo such as `thicknes_m` is an error, not a silently ignored value.
class JsonObjectReader {
 public:
  /// @param[in] source  name of the input shown in messages (usually the file name)
  /// @param[in] path    key path of this object ("" for the top level)
  /// @param[in] value   the JSON value, which must be an object
  JsonObjectReader(std::string source, std::string path, const nlohmann::json& value);

  bool has(const std::string& key) const;

  /// Required finite number; `rule` is checked by the caller through the range helpers.
  double number(const std::string& key) const;
  double number_or(const std::string& key, double fallback) const;
  /// Number that must be > 0 (strictly positive).
  double positive(const std::string& key) const;
  double positive_or(const std::string& key, double fallback) const;
  /// Number that must be >= 0.
  double non_negative_or(const std::string& key, double fallback) const;
  /// Number in [lo, hi].
  double in_range_or(const std::string& key, double fallback, double lo, double hi) const;
  long integer_or(const std::string& key, long fallback, long lo, long hi) const;
  bool boolean_or(const std::string& key, bool fallback) const;
  std::string string(const std::string& key) const;
  std::string string_or(const std::string& key, const std::string& fallback) const;
  /// String that must be one of `choices`.
  std::string choice_or(const std::string& key, const std::string& fallback,
                        const std::vector<std::string>& choices) const;
  /// Array of exactly two finite numbers, e.g. a point [x, y].
  std::array<double, 2> pair(const std::string& key) const;
  std::array<double, 2> pair_or(const std::string& key, std::array<double, 2> fallback) const;
  /// Array of points [[x, y], ...] with at least `min_count` entries.
  std::vector<std::array<double, 2>> points(const std::string& key, std::size_t min_count) const;

  /// Child object (required / optional).
  JsonObjectReader object(const std::string& key) const;
  std::optional<JsonObjectReader> object_if(const std::string& key) const;
  /// Array of objects; empty if the key is absent.
  std::vector<JsonObjectReader> objects(const std::string& key) const;

  /// Throws InputError naming the first key that was never read.
  void finish() const;

  /// Throws InputError: `<source>: <path.key> = <value> <rule>`.
  [[noreturn]] void fail(const std::string& key, const std::string& rule) const;
  /// Throws InputError about this object as a whole.
  [[noreturn]] void fail_object(const std::string& rule) const;

  const std::string& source() const { return source_; }
  std::string key_path(const std::string& key) const;
  const nlohmann::json& json() const { return value_; }

 private:
  const nlohmann::json& at(const std::string& key) const;

  std::string source_;
  std::string path_;
  const nlohmann::json& value_;
  mutable std::set<std::string> used_;
};

/// Deepest nesting of arrays and objects a pvdfkit JSON file may have (they need about 4).
inline constexpr std::size_t max_json_depth = 64;

/// Parses a JSON file strictly (no comments, no trailing commas). Throws InputError naming
/// the file and the line/column for a syntax error, or the file for a missing/unreadable one.
nlohmann::json read_json_file(const std::string& path);
/// Parses JSON text; `source` names it in messages. Linear in the text, without recursion or
/// backtracking; refuses nesting deeper than max_json_depth and a key repeated in one object.
nlohmann::json parse_json_text(const std::string& text, const std::string& source);

/// Shortens a JSON value for an error message (at most 60 characters, control bytes escaped);
/// iterative, so any value is safe.
std::string json_excerpt(const nlohmann::json& value);

}  // namespace pvdf
