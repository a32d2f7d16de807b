// Error types shared by every pvdfkit module: bad input (exit 2) versus numerical failure (exit 3).
#pragma once

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

/// Exit codes of the `pvdfkit` command, the same for every subcommand.
namespace exit_code {
inline constexpr int success = 0;
inline constexpr int internal = 1;   ///< a bug: an unexpected exception (reported, never an abort)
inline constexpr int bad_input = 2;  ///< bad input or usage
inline constexpr int numerical = 3;  ///< numerical failure reported as such
inline constexpr int interrupted = 130;  ///< stopped by the user (Ctrl-C) after saving its work
}  // namespace exit_code

}  // namespace pvdf
