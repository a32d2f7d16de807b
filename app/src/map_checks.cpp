// Checks shared by `compare` and `rays` (built with or without the FEM modules): is a path a scene
// or a map, and which compared presses a map's spacing cannot resolve.
#include "map_checks.hpp"

#include "command.hpp"

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
  if (map.nx() < 2 || map.ny() < 2) return 0;
  const double h = std::max(map.x_m[1] - map.x_m[0], map.y_m[1] - map.y_m[0]);
  int n = 0;
  for (const auto& p : presses) {
    for (std::size_t k = 0; k < map.ne(); ++k) {
      const double d = std::hypot(p.x_m - map.electrode_centers_m[k][0], p.y_m - map.electrode_centers_m[k][1]);
      if (d < 2 * h) {
        char buf[320];
        std::snprintf(buf, sizeof buf,
                      "line %zu: the press is %.1f mm from electrode %s, closer than twice the map's spacing "
                      "(%.1f mm): the map's interpolation error alone can reach tens of %% there; use a map with "
                      "spacing <= %.1f mm, or compare against the scene itself (pvdfkit compare SCENE %s)",
                      p.line, d * 1e3, map.electrode_names[k].c_str(), h * 1e3, d * 1e3 / 2, "CSV");
        warn(buf);
        ++n;
        break;
      }
    }
  }
  return n;
}

}  // namespace pvdf::app
