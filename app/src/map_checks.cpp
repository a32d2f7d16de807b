// Checks shared by `compare` and `rays` (built with or without the FEM modules): is a path a scene
// or a map, and the warning for the compared presses a map's spacing cannot resolve (the rule is
// mapping::presses_map_cannot_resolve).
#include "map_checks.hpp"

#include "command.hpp"

#include "pvdf/core/error.hpp"
#include "pvdf/core/io.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>

namespace pvdf::app {

bool is_scene_file(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  char c = 0;
  while (in.get(c)) {
    if (c == ' ' || c == '\t' || c == '\r' || c == '\n') continue;
    return c == '{';
  }
  return false;
}

int warn_if_map_too_coarse(const pvdf::mapping::ChargeMap& map, const std::vector<pvdf::mapping::MeasuredPress>& presses) {
  const auto unresolved = pvdf::mapping::presses_map_cannot_resolve(map, presses);
  for (const auto& u : unresolved) {
    char buf[320];
    std::snprintf(buf, sizeof buf,
                  "line %zu: the press is %.1f mm from electrode %s, closer than twice the map's spacing "
                  "(%.1f mm): the map's interpolation error alone can reach tens of %% there; use a map with "
                  "spacing <= %.1f mm, or compare against the scene itself (pvdfkit compare SCENE %s)",
                  u.line, u.distance_m * 1e3, map.electrode_names[u.electrode].c_str(), u.spacing_m * 1e3,
                  u.distance_m * 1e3 / 2, "CSV");
    warn(buf);
  }
  return static_cast<int>(unresolved.size());
}

void check_measured_plausible(const std::vector<pvdf::mapping::MeasuredPress>& presses, const std::string& source,
                              const std::vector<std::string>& electrode_names) {
  for (const auto& p : presses) {
    const std::string at = source + ":" + std::to_string(p.line) + ": ";
    if (!(p.force_N > 0 && p.force_N <= 1e4)) {
      throw pvdf::InputError(at + "force_N = " + pvdf::format_g(p.force_N) +
                             " must lie in (0, 1e4] N (a press pushes the film); is the unit mN or g?");
    }
    for (std::size_t k = 0; k < p.charge_C.size(); ++k) {
      if (!(std::abs(p.charge_C[k]) <= 1e-6)) {
        const std::string name = k < electrode_names.size() ? electrode_names[k] : std::to_string(k);
        throw pvdf::InputError(at + "charge_" + name + "_C = " + pvdf::format_g(p.charge_C[k]) +
                               " exceeds 1e-6 C, beyond any film's charge: the values look like pC; give coulombs "
                               "(18 pC = 1.8e-11 C)");
      }
    }
  }
}

std::vector<double> parse_charges(const std::string& text, const pvdf::mapping::ChargeMap& map) {
  const auto q = pvdf::parse_number_list(text, "--charges-C");
  if (q.size() != map.ne()) {
    std::string order;
    for (const auto& n : map.electrode_names) order += (order.empty() ? "" : ",") + n;
    throw pvdf::InputError("--charges-C " + pvdf::quote_cell(text) + ": " + std::to_string(q.size()) +
                           " charges for a map of " + std::to_string(map.ne()) + " electrodes; give one charge (C) per " +
                           "electrode in the map's order " + order);
  }
  double map_max_C = 0;
  for (const double c : map.charge_C) {
    if (std::isfinite(c)) map_max_C = std::max(map_max_C, std::abs(c));
  }
  double given_max_C = 0;
  for (const double c : q) given_max_C = std::max(given_max_C, std::abs(c));
  if (map_max_C > 0 && given_max_C > 1e3 * map_max_C) {
    const bool pico = given_max_C * 1e-12 <= 10 * map_max_C;
    throw pvdf::InputError("--charges-C " + pvdf::quote_cell(text) + ": " + pvdf::format_g(given_max_C) +
                           " C is more than 1000 times the map's largest charge (" + pvdf::format_g(map_max_C) + " C)" +
                           (pico ? "; these look like pC: the unit is coulombs (1 pC = 1e-12 C), e.g. " +
                                       pvdf::format_g(q[0] * 1e-12) + " for " + pvdf::format_g(q[0])
                                 : "; the unit is coulombs: check the charge amplifier's gain"));
  }
  return q;
}

}  // namespace pvdf::app
