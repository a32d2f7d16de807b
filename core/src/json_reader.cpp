// Strict JSON reading with key paths in every message.
#include "pvdf/core/json_reader.hpp"

#include "pvdf/core/error.hpp"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <limits>
#include <utility>
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
  // Iterative and bounded: a value nested 10^5 deep or a megabyte long costs ~60 characters of
  // work, never a recursion per level or a full dump.
  constexpr std::size_t limit = 60;
  std::string out;
  struct Frame {
    const nlohmann::json* node;
    nlohmann::json::const_iterator next;
    bool first;
  };
  std::vector<Frame> stack;
  auto scalar = [](const nlohmann::json& v) {
    return v.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace);
  };
  auto open = [&](const nlohmann::json& v) {
    if (v.is_structured() && !v.empty()) {
      out += v.is_object() ? '{' : '[';
      stack.push_back({&v, v.cbegin(), true});
    } else {
      out += v.is_structured() ? (v.is_object() ? "{}" : "[]") : scalar(v);
    }
  };
  open(value);
  while (!stack.empty() && out.size() <= limit) {
    Frame& f = stack.back();
    if (f.next == f.node->cend()) {
      out += f.node->is_object() ? '}' : ']';
      stack.pop_back();
      continue;
    }
    if (!f.first) out += ',';
    f.first = false;
    const auto it = f.next++;
    if (f.node->is_object()) out += scalar(nlohmann::json(it.key())) + ':';
    open(*it);  // may grow the stack: `f` is not used after this
  }
  if (out.size() > limit) out = out.substr(0, limit - 3) + "...";
  return escape_control_bytes(out);
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

namespace {

/// Line and column (1-based) of byte `offset` in `text`.
std::pair<std::size_t, std::size_t> line_column(const std::string& text, std::size_t offset) {
  std::size_t line = 1, column = 1;
  for (std::size_t i = 0; i < offset && i < text.size(); ++i) {
    if (text[i] == '\n') {
      ++line;
      column = 1;
    } else {
      ++column;
    }
  }
  return {line, column};
}

std::string position(const std::string& source, const std::string& text, std::size_t offset) {
  const auto [line, column] = line_column(text, offset);
  return source + ":" + std::to_string(line) + ":" + std::to_string(column);
}

/// Offset of the first bracket that nests deeper than `max_depth`, or npos. One pass, no
/// recursion; strings (with escapes) are skipped.
std::size_t too_deep_at(const std::string& text, std::size_t max_depth) {
  std::size_t depth = 0;
  bool in_string = false, escaped = false;
  for (std::size_t i = 0; i < text.size(); ++i) {
    const char c = text[i];
    if (in_string) {
      if (escaped) escaped = false;
      else if (c == '\\') escaped = true;
      else if (c == '"') in_string = false;
    } else if (c == '"') {
      in_string = true;
    } else if (c == '[' || c == '{') {
      if (++depth > max_depth) return i;
    } else if ((c == ']' || c == '}') && depth > 0) {
      --depth;
    }
  }
  return std::string::npos;
}

/// The key whose value holds byte `offset` — the last `"key":` before it with no string
/// opened since — or "". One forward pass, no backtracking.
std::string key_before(const std::string& text, std::size_t offset) {
  std::string key, last_string;
  bool string_since_colon = true;
  for (std::size_t i = 0; i < offset && i < text.size(); ++i) {
    const char c = text[i];
    if (c == '"') {
      std::size_t j = i + 1;
      std::string s;
      while (j < offset && j < text.size() && text[j] != '"') {
        if (text[j] == '\\' && j + 1 < text.size()) s += text[j++];
        s += text[j++];
      }
      if (j >= offset || j >= text.size()) {  // the error is inside this string
        string_since_colon = true;
        break;
      }
      last_string = s;
      string_since_colon = true;
      i = j;
    } else if (c == ':') {
      key = last_string;
      string_since_colon = false;
    }
  }
  return string_since_colon ? std::string() : key;
}

/// Thrown from the parser callback on a repeated key.
struct DuplicateKey {
  std::string path;
};

}  // namespace

nlohmann::json parse_json_text(const std::string& text, const std::string& source) {
  // Nesting first: the parser and every later walk over the value stay shallow.
  const std::size_t deep = too_deep_at(text, max_json_depth);
  if (deep != std::string::npos) {
    throw InputError(position(source, text, deep) + ": JSON nested deeper than " + std::to_string(max_json_depth) +
                     " levels; pvdfkit files nest a few levels: fix the file");
  }
  // Duplicate keys: a key path per open object; "radius_m" twice in one object is refused
  // (JSON leaves it undefined, and a silent "last one wins" hides typos).
  std::vector<std::pair<std::string, std::set<std::string>>> objects;
  std::string pending_key;
  std::vector<std::string> path;
  const nlohmann::json::parser_callback_t callback = [&](int, nlohmann::json::parse_event_t event,
                                                         nlohmann::json& parsed) {
    using E = nlohmann::json::parse_event_t;
    switch (event) {
      case E::object_start:
      case E::array_start: {
        std::string here = objects.empty() ? std::string() : objects.back().first;
        if (!pending_key.empty()) here += (here.empty() ? "" : ".") + pending_key;
        pending_key.clear();
        objects.push_back({here, {}});
        break;
      }
      case E::key: {
        const std::string k = parsed.get<std::string>();
        if (!objects.empty() && !objects.back().second.insert(k).second) {
          const std::string& where = objects.back().first;
          throw DuplicateKey{where.empty() ? k : where + "." + k};
        }
        pending_key = k;
        break;
      }
      case E::object_end:
      case E::array_end:
        if (!objects.empty()) objects.pop_back();
        break;
      case E::value: pending_key.clear(); break;
    }
    return true;
  };
  try {
    return nlohmann::json::parse(text, callback);
  } catch (const DuplicateKey& d) {
    throw InputError(source + ": duplicate key " + escape_control_bytes(d.path) +
                     "; each key may appear once in an object: remove one of them");
  } catch (const nlohmann::json::parse_error& e) {
    // Line and column of the failure, and the key just before it, so that a NaN or a stray
    // character is reported against the key the user wrote it under.
    const std::size_t offset = std::min<std::size_t>(e.byte > 0 ? e.byte - 1 : 0, text.size());
    const std::string key = key_before(text, offset);
    std::string token = text.substr(offset, 12);
    for (char& c : token) {
      if (c == '\n' || c == '\r' || c == '\t') c = ' ';
    }
    std::string msg = position(source, text, offset) + ": invalid JSON";
    if (!key.empty()) msg += " in the value of key \"" + escape_control_bytes(key) + "\"";
    if (!token.empty()) msg += " near '" + escape_control_bytes(token) + "'";
    const bool nan_like = token.rfind("NaN", 0) == 0 || token.rfind("nan", 0) == 0 ||
                          token.rfind("Inf", 0) == 0 || token.rfind("-Inf", 0) == 0;
    if (nan_like) {
      msg += "; NaN and Infinity are not numbers in JSON: write a finite number";
    } else if (offset >= text.size()) {
      msg += "; the file ends too early (truncated?): complete it";
    } else {
      msg += "; fix the syntax (strict JSON: double quotes, no comments, no trailing commas)";
    }
    throw InputError(msg);
  } catch (const nlohmann::json::exception& e) {
    // e.g. a number too large for a double ("1e400"): name the key it was written under.
    const std::string what = e.what();
    const auto q1 = what.find('\'');
    const auto q2 = q1 == std::string::npos ? q1 : what.find('\'', q1 + 1);
    if (q2 != std::string::npos) {
      const std::string token = what.substr(q1 + 1, q2 - q1 - 1);
      const auto at = text.find(token);
      const std::string key = at == std::string::npos ? std::string() : key_before(text, at);
      throw InputError((at == std::string::npos ? source : position(source, text, at)) + ": number '" +
                       escape_control_bytes(token) + "'" +
                       (key.empty() ? "" : " in the value of key \"" + escape_control_bytes(key) + "\"") +
                       " is out of the range of a double (not finite); write a finite number");
    }
    throw InputError(source + ": invalid JSON (" + escape_control_bytes(what) + "); fix the file");
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
