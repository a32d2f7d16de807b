// Strict JSON reading with key paths in every message.
#include "pvdf/core/json_reader.hpp"

#include "pvdf/core/error.hpp"

#include <cmath>
#include <fstream>
#include <limits>
#include <regex>
#include <sstream>

namespace pvdf {

namespace {

std::string type_name(const nlohmann::json& v) {
  if (v.is_number()) return "a number";
  if (v.is_string()) return "a string";
  if (v.is_boolean()) return "a boolean";
  if (v.is_array()) return "an array";
  if (v.is_object()) return "an object";
  if (v.is_null()) return "null";
  return "a value";
}

std::string format_number(double x) {
  std::ostringstream os;
  os.precision(6);
  os << x;
  return os.str();
}

}  // namespace

std::string json_excerpt(const nlohmann::json& value) {
  std::string s = value.dump();
  if (s.size() > 60) s = s.substr(0, 57) + "...";
  return s;
}

JsonObjectReader::JsonObjectReader(std::string source, std::string path, const nlohmann::json& value)
    : source_(std::move(source)), path_(std::move(path)), value_(value) {
  if (!value_.is_object()) {
    throw InputError(source_ + ": " + (path_.empty() ? std::string("the top level") : path_) +
                     " is " + type_name(value_) + " (" + json_excerpt(value_) +
                     "); it must be a JSON object {...}");
  }
}

std::string JsonObjectReader::key_path(const std::string& key) const {
  return path_.empty() ? key : path_ + "." + key;
}

void JsonObjectReader::fail(const std::string& key, const std::string& rule) const {
  std::string shown = has(key) ? json_excerpt(value_.at(key)) : std::string("(missing)");
  throw InputError(source_ + ": " + key_path(key) + " = " + shown + " " + rule);
}

void JsonObjectReader::fail_object(const std::string& rule) const {
  throw InputError(source_ + ": " + (path_.empty() ? std::string("top level") : path_) + " " + rule);
}

bool JsonObjectReader::has(const std::string& key) const { return value_.contains(key); }

const nlohmann::json& JsonObjectReader::at(const std::string& key) const {
  if (!has(key)) {
    throw InputError(source_ + ": " + key_path(key) + " is missing; it is required (see docs/scene.md)");
  }
  used_.insert(key);
  return value_.at(key);
}

double JsonObjectReader::number(const std::string& key) const {
  const auto& v = at(key);
  if (!v.is_number()) fail(key, "is " + type_name(v) + "; it must be a number");
  const double x = v.get<double>();
  if (!std::isfinite(x)) fail(key, "is not finite; it must be a finite number");
  return x;
}

double JsonObjectReader::number_or(const std::string& key, double fallback) const {
  return has(key) ? number(key) : fallback;
}

double JsonObjectReader::positive(const std::string& key) const {
  const double x = number(key);
  if (!(x > 0)) fail(key, "must be > 0");
  return x;
}

double JsonObjectReader::positive_or(const std::string& key, double fallback) const {
  return has(key) ? positive(key) : fallback;
}

double JsonObjectReader::non_negative_or(const std::string& key, double fallback) const {
  if (!has(key)) return fallback;
  const double x = number(key);
  if (!(x >= 0)) fail(key, "must be >= 0");
  return x;
}

double JsonObjectReader::in_range_or(const std::string& key, double fallback, double lo,
                                     double hi) const {
  if (!has(key)) return fallback;
  const double x = number(key);
  if (!(x >= lo && x <= hi)) {
    fail(key, "must lie in [" + format_number(lo) + ", " + format_number(hi) + "]");
  }
  return x;
}

long JsonObjectReader::integer_or(const std::string& key, long fallback, long lo, long hi) const {
  if (!has(key)) return fallback;
  const auto& v = at(key);
  if (!v.is_number_integer()) fail(key, "is " + type_name(v) + "; it must be a whole number");
  const long x = v.get<long>();
  if (x < lo || x > hi) {
    fail(key, "must lie in [" + std::to_string(lo) + ", " + std::to_string(hi) + "]");
  }
  return x;
}

bool JsonObjectReader::boolean_or(const std::string& key, bool fallback) const {
  if (!has(key)) return fallback;
  const auto& v = at(key);
  if (!v.is_boolean()) fail(key, "is " + type_name(v) + "; it must be true or false");
  return v.get<bool>();
}

std::string JsonObjectReader::string(const std::string& key) const {
  const auto& v = at(key);
  if (!v.is_string()) fail(key, "is " + type_name(v) + "; it must be a string");
  return v.get<std::string>();
}

std::string JsonObjectReader::string_or(const std::string& key, const std::string& fallback) const {
  return has(key) ? string(key) : fallback;
}

std::string JsonObjectReader::choice_or(const std::string& key, const std::string& fallback,
                                        const std::vector<std::string>& choices) const {
  const std::string s = string_or(key, fallback);
  for (const auto& c : choices) {
    if (s == c) return s;
  }
  std::string list;
  for (const auto& c : choices) list += (list.empty() ? "" : ", ") + ("\"" + c + "\"");
  fail(key, "is not allowed; use one of " + list);
}

std::array<double, 2> JsonObjectReader::pair(const std::string& key) const {
  const auto& v = at(key);
  if (!v.is_array() || v.size() != 2 || !v[0].is_number() || !v[1].is_number()) {
    fail(key, "must be an array of two numbers [x, y]");
  }
  const std::array<double, 2> p{v[0].get<double>(), v[1].get<double>()};
  if (!std::isfinite(p[0]) || !std::isfinite(p[1])) fail(key, "must hold finite numbers");
  return p;
}

std::array<double, 2> JsonObjectReader::pair_or(const std::string& key,
                                                std::array<double, 2> fallback) const {
  return has(key) ? pair(key) : fallback;
}

std::vector<std::array<double, 2>> JsonObjectReader::points(const std::string& key,
                                                            std::size_t min_count) const {
  const auto& v = at(key);
  if (!v.is_array()) fail(key, "must be an array of points [[x, y], ...]");
  if (v.size() < min_count) {
    fail(key, "has " + std::to_string(v.size()) + " points; it needs at least " +
                  std::to_string(min_count));
  }
  std::vector<std::array<double, 2>> out;
  for (std::size_t i = 0; i < v.size(); ++i) {
    const auto& p = v[i];
    if (!p.is_array() || p.size() != 2 || !p[0].is_number() || !p[1].is_number() ||
        !std::isfinite(p[0].get<double>()) || !std::isfinite(p[1].get<double>())) {
      throw InputError(source_ + ": " + key_path(key) + "[" + std::to_string(i) + "] = " +
                       json_excerpt(p) + " must be a point [x, y] of two finite numbers");
    }
    out.push_back({p[0].get<double>(), p[1].get<double>()});
  }
  return out;
}

JsonObjectReader JsonObjectReader::object(const std::string& key) const {
  return JsonObjectReader(source_, key_path(key), at(key));
}

std::optional<JsonObjectReader> JsonObjectReader::object_if(const std::string& key) const {
  if (!has(key)) return std::nullopt;
  return JsonObjectReader(source_, key_path(key), at(key));
}

std::vector<JsonObjectReader> JsonObjectReader::objects(const std::string& key) const {
  std::vector<JsonObjectReader> out;
  if (!has(key)) return out;
  const auto& v = at(key);
  if (!v.is_array()) fail(key, "must be an array of objects [{...}, ...]");
  for (std::size_t i = 0; i < v.size(); ++i) {
    out.emplace_back(source_, key_path(key) + "[" + std::to_string(i) + "]", v[i]);
  }
  return out;
}

void JsonObjectReader::finish() const {
  for (auto it = value_.begin(); it != value_.end(); ++it) {
    if (used_.count(it.key()) == 0) {
      throw InputError(source_ + ": unknown key " + key_path(it.key()) + " = " +
                       json_excerpt(it.value()) +
                       "; remove it or check its spelling (docs/scene.md lists the keys)");
    }
  }
}

nlohmann::json parse_json_text(const std::string& text, const std::string& source) {
  try {
    return nlohmann::json::parse(text);
  } catch (const nlohmann::json::parse_error& e) {
    // Work out line and column of the failure, and the key just before it, so that a NaN or a
    // stray character is reported against the key the user wrote it under.
    std::size_t offset = e.byte > 0 ? e.byte - 1 : 0;
    if (offset > text.size()) offset = text.size();
    std::size_t line = 1, column = 1;
    for (std::size_t i = 0; i < offset; ++i) {
      if (text[i] == '\n') {
        ++line;
        column = 1;
      } else {
        ++column;
      }
    }
    std::string before = text.substr(0, offset);
    std::string key;
    static const std::regex key_re("\"([^\"\\\\]+)\"\\s*:\\s*[^\"]*$");
    std::smatch m;
    if (std::regex_search(before, m, key_re)) key = m[1];
    std::string token = text.substr(offset, 12);
    for (char& c : token) {
      if (c == '\n' || c == '\r' || c == '\t') c = ' ';
    }
    std::string msg = source + ":" + std::to_string(line) + ":" + std::to_string(column) +
                      ": invalid JSON";
    if (!key.empty()) msg += " in the value of key \"" + key + "\"";
    if (!token.empty()) msg += " near '" + token + "'";
    const bool nan_like = token.rfind("NaN", 0) == 0 || token.rfind("nan", 0) == 0 ||
                          token.rfind("Inf", 0) == 0 || token.rfind("-Inf", 0) == 0;
    if (nan_like) {
      msg += "; NaN and Infinity are not numbers in JSON: write a finite number";
    } else {
      msg += "; fix the syntax (strict JSON: double quotes, no comments, no trailing commas)";
    }
    throw InputError(msg);
  } catch (const nlohmann::json::exception& e) {
    // e.g. a number too large for a double ("1e400"): name the key it was written under.
    std::string what = e.what();
    std::string key;
    const auto q1 = what.find('\'');
    const auto q2 = q1 == std::string::npos ? q1 : what.find('\'', q1 + 1);
    if (q2 != std::string::npos) {
      const std::string token = what.substr(q1 + 1, q2 - q1 - 1);
      const auto at = text.find(token);
      if (at != std::string::npos) {
        static const std::regex key_re("\"([^\"\\\\]+)\"\\s*:\\s*[^\"]*$");
        std::smatch m;
        const std::string before = text.substr(0, at);
        if (std::regex_search(before, m, key_re)) key = m[1];
      }
      throw InputError(source + ": number '" + token + "'" + (key.empty() ? "" : " in the value of key \"" + key + "\"") +
                       " is out of the range of a double (not finite); write a finite number");
    }
    throw InputError(source + ": invalid JSON (" + what + "); fix the file");
  }
}

nlohmann::json read_json_file(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) {
    throw InputError(path + ": cannot open the file; check the path and its permissions");
  }
  std::ostringstream ss;
  ss << in.rdbuf();
  if (in.bad()) throw InputError(path + ": read error; check the file");
  return parse_json_text(ss.str(), path);
}

}  // namespace pvdf
