// Error types shared by every pvdfkit module: bad input (exit 2) versus numerical failure (exit 3).
#pragma once

#include <cstdio>
#include <stdexcept>
#include <string>

namespace pvdf {

/// Bad input or I/O: a scene file, CSV, map, filter, device stream or flag that cannot be used.
/// The message names the input, the value, the rule and the fix, on one line, e.g.
/// `scene.json: membrane.thickness_m = -2.5e-05 must be > 0`. The command line turns it into
/// `error: <message>` on stderr and exit code 2.
class InputError : public std::runtime_error {
 public:
  explicit InputError(const std::string& message) : std::runtime_error(message) {}
};

/// A numerical outcome that makes a result unusable (no convergence, singular system,
/// ill-conditioned inversion). Solvers normally report these as a status in their Summary;
/// this exception exists for code paths that cannot return one. The command line turns it
/// into exit code 3.
class NumericalError : public std::runtime_error {
 public:
  explicit NumericalError(const std::string& message) : std::runtime_error(message) {}
};

/// `text` made safe for one line on a terminal: control bytes (NUL, ESC, newlines, DEL) and bytes
/// that are not valid UTF-8 become `\xNN`, so a garbage file can neither cut a message short nor
/// drive the terminal. Use it wherever a message quotes text from an input.
inline std::string escape_control_bytes(const std::string& text) {
  std::string out;
  out.reserve(text.size());
  auto hex = [&out](unsigned char c) {
    char buf[8];
    std::snprintf(buf, sizeof buf, "\\x%02x", c);
    out += buf;
  };
  for (std::size_t i = 0; i < text.size();) {
    const auto c = static_cast<unsigned char>(text[i]);
    if (c < 0x80) {
      if (c < 0x20 || c == 0x7f) hex(c);
      else out += static_cast<char>(c);
      ++i;
      continue;
    }
    // A well-formed UTF-8 sequence (no overlongs, no C1 controls U+0080..U+009F) is kept.
    const std::size_t n = (c >= 0xc2 && c <= 0xdf) ? 2 : (c >= 0xe0 && c <= 0xef) ? 3 : (c >= 0xf0 && c <= 0xf4) ? 4 : 0;
    bool ok = n > 0 && i + n <= text.size();
    for (std::size_t k = 1; ok && k < n; ++k) ok = (static_cast<unsigned char>(text[i + k]) & 0xc0) == 0x80;
    if (ok && n == 2 && c == 0xc2 && static_cast<unsigned char>(text[i + 1]) < 0xa0) ok = false;
    if (ok && n == 3 && c == 0xe0 && static_cast<unsigned char>(text[i + 1]) < 0xa0) ok = false;
    if (ok && n == 4 && c == 0xf0 && static_cast<unsigned char>(text[i + 1]) < 0x90) ok = false;
    if (ok) {
      out.append(text, i, n);
      i += n;
    } else {
      hex(c);
      ++i;
    }
  }
  return out;
}

/// Exit codes of the `pvdfkit` command, the same for every subcommand.
namespace exit_code {
inline constexpr int success = 0;
inline constexpr int internal = 1;   ///< a bug: an unexpected exception (reported, never an abort)
inline constexpr int bad_input = 2;  ///< bad input or usage
inline constexpr int numerical = 3;  ///< numerical failure reported as such
inline constexpr int interrupted = 130;  ///< stopped by the user (Ctrl-C) after saving its work
}  // namespace exit_code

}  // namespace pvdf
