// Colours (line cycle, sequential and diverging maps) and contour extraction by marching squares.
#include "detail.hpp"

#include "pvdf/core/assert.hpp"
#include "pvdf/core/error.hpp"

#include <algorithm>
#include <cstring>
#include <unordered_map>

namespace pvdf::plot {
namespace detail {

void check_grid(const Grid& g, const char* what) {
  if (g.values.size() != g.nx * g.ny) {
    throw InputError(std::string("plot ") + what + ": grid has " + std::to_string(g.values.size()) +
                     " values but nx * ny = " + std::to_string(g.nx * g.ny) + "; give one value per node");
  }
}

/// Checks that a printf format takes exactly one floating-point number (%f %e %g, with flags,
/// width and precision), so a caller's format cannot read past its argument.
bool one_double_format(const std::string& f) {
  int n = 0;
  for (std::size_t i = 0; i < f.size(); ++i) {
    if (f[i] != '%') continue;
    if (i + 1 < f.size() && f[i + 1] == '%') { ++i; continue; }
    std::size_t k = i + 1;
    while (k < f.size() && std::strchr("-+ #0", f[k])) ++k;
    while (k < f.size() && std::isdigit(static_cast<unsigned char>(f[k]))) ++k;
    if (k < f.size() && f[k] == '.') {
      ++k;
      while (k < f.size() && std::isdigit(static_cast<unsigned char>(f[k]))) ++k;
    }
    if (k >= f.size() || !std::strchr("feEgGF", f[k])) return false;
    ++n;
    i = k;
  }
  return n == 1;
}

}  // namespace detail

namespace {
using detail::P2;
using detail::finite;

template <std::size_t N>
Color interpolate_stops(const Color (&stops)[N], double t) {
  if (!finite(t)) t = 0;
  t = std::clamp(t, 0.0, 1.0);
  const double s = t * static_cast<double>(N - 1);
  const std::size_t k = std::min<std::size_t>(static_cast<std::size_t>(s), N - 2);
  const double f = s - static_cast<double>(k);
  auto mix = [f](unsigned char a, unsigned char b) {
    return static_cast<unsigned char>(std::lround(a + (static_cast<double>(b) - a) * f));
  };
  return {mix(stops[k].r, stops[k + 1].r), mix(stops[k].g, stops[k + 1].g), mix(stops[k].b, stops[k + 1].b)};
}

}  // namespace

Color cycle_color(std::size_t index) {
  // Okabe–Ito palette (distinguishable with the common colour-vision deficiencies).
  static const Color colors[] = {{0, 114, 178},  {213, 94, 0},   {0, 158, 115}, {230, 159, 0},
                                 {204, 121, 167}, {86, 180, 233}, {0, 0, 0},     {170, 150, 0}};
  return colors[index % (sizeof colors / sizeof colors[0])];
}

Color colormap(double t) {
  // Dark violet → blue → teal → green → yellow, lightness increasing monotonically.
  static const Color stops[] = {{68, 1, 84},    {72, 40, 120},  {62, 74, 137},  {49, 104, 142}, {38, 130, 142},
                                {31, 158, 137}, {53, 183, 121}, {109, 205, 89}, {180, 222, 44}, {253, 231, 37}};
  return interpolate_stops(stops, t);
}

Color colormap_diverging(double t) {
  static const Color stops[] = {{30, 60, 140},  {60, 110, 190}, {130, 170, 215}, {200, 220, 238}, {255, 255, 255},
                                {245, 205, 190}, {225, 140, 115}, {190, 60, 50},  {120, 15, 30}};
  return interpolate_stops(stops, t);
}

std::vector<std::vector<std::array<double, 2>>> contour_lines(const Grid& g, double level) {
  detail::check_grid(g, "contour");
  std::vector<std::vector<P2>> lines;
  if (g.nx < 2 || g.ny < 2 || !finite(level)) return lines;
  const std::size_t nx = g.nx, ny = g.ny, n_h = (nx - 1) * ny;
  auto hid = [&](std::size_t i, std::size_t j) { return j * (nx - 1) + i; };   // (i,j)–(i+1,j)
  auto vid = [&](std::size_t i, std::size_t j) { return n_h + j * nx + i; };  // (i,j)–(i,j+1)
  auto node = [&](std::size_t i, std::size_t j) {
    return P2{g.x0 + (g.x1 - g.x0) * static_cast<double>(i) / static_cast<double>(nx - 1),
              g.y0 + (g.y1 - g.y0) * static_cast<double>(j) / static_cast<double>(ny - 1)};
  };
  std::unordered_map<std::size_t, P2> point;  // crossing on each cut edge
  auto crossing = [&](std::size_t id, std::size_t ia, std::size_t ja, std::size_t ib, std::size_t jb) {
    if (point.count(id)) return;
    const double a = g.at(ia, ja), b = g.at(ib, jb);
    const double t = std::clamp((level - a) / (b - a), 0.0, 1.0);
    const P2 pa = node(ia, ja), pb = node(ib, jb);
    point[id] = {pa[0] + t * (pb[0] - pa[0]), pa[1] + t * (pb[1] - pa[1])};
  };
  std::vector<std::array<std::size_t, 2>> segs;
  for (std::size_t j = 0; j + 1 < ny; ++j) {
    for (std::size_t i = 0; i + 1 < nx; ++i) {
      const double v[4] = {g.at(i, j), g.at(i + 1, j), g.at(i + 1, j + 1), g.at(i, j + 1)};
      if (!finite(v[0]) || !finite(v[1]) || !finite(v[2]) || !finite(v[3])) continue;
      int code = 0;
      for (int k = 0; k < 4; ++k) code |= (v[k] >= level ? 1 : 0) << k;
      if (code == 0 || code == 15) continue;
      const std::size_t e[4] = {hid(i, j), vid(i + 1, j), hid(i, j + 1), vid(i, j)};
      const bool cut[4] = {((code >> 0) & 1) != ((code >> 1) & 1), ((code >> 1) & 1) != ((code >> 2) & 1),
                           ((code >> 3) & 1) != ((code >> 2) & 1), ((code >> 0) & 1) != ((code >> 3) & 1)};
      if (cut[0]) crossing(e[0], i, j, i + 1, j);
      if (cut[1]) crossing(e[1], i + 1, j, i + 1, j + 1);
      if (cut[2]) crossing(e[2], i, j + 1, i + 1, j + 1);
      if (cut[3]) crossing(e[3], i, j, i, j + 1);
      if (code == 5 || code == 10) {
        // Saddle: the cell-centre average decides which pair of opposite corners is joined.
        const bool centre_high = (v[0] + v[1] + v[2] + v[3]) / 4 >= level;
        const bool isolate_corners_0_2 = (code == 5) != centre_high;  // cut off corners 0 and 2
        if (isolate_corners_0_2) {
          segs.push_back({e[0], e[3]});
          segs.push_back({e[1], e[2]});
        } else {
          segs.push_back({e[0], e[1]});
          segs.push_back({e[2], e[3]});
        }
      } else {
        std::size_t a = 0, b = 0;
        int found = 0;
        for (int k = 0; k < 4; ++k) {
          if (!cut[k]) continue;
          (found == 0 ? a : b) = e[k];
          ++found;
        }
        PVDF_ASSERT(found == 2, "a contour cell that is not a saddle cuts exactly two of its edges");
        if (found == 2) segs.push_back({a, b});
      }
    }
  }
  // Chain the segments through their shared edges.
  std::unordered_map<std::size_t, std::array<std::size_t, 2>> by_edge;
  const std::size_t none = static_cast<std::size_t>(-1);
  for (std::size_t s = 0; s < segs.size(); ++s) {
    for (std::size_t e : segs[s]) {
      auto it = by_edge.find(e);
      if (it == by_edge.end()) by_edge[e] = {s, none};
      else it->second[1] = s;
    }
  }
  std::vector<char> used(segs.size(), 0);
  auto other_segment = [&](std::size_t edge, std::size_t s) {
    const auto& pair = by_edge[edge];
    return pair[0] == s ? pair[1] : pair[0];
  };
  for (std::size_t s0 = 0; s0 < segs.size(); ++s0) {
    if (used[s0]) continue;
    used[s0] = 1;
    std::vector<std::size_t> chain{segs[s0][0], segs[s0][1]};
    // forward from the second edge
    for (std::size_t s = s0, e = segs[s0][1];;) {
      const std::size_t n = other_segment(e, s);
      if (n == none || used[n]) break;
      used[n] = 1;
      e = segs[n][0] == e ? segs[n][1] : segs[n][0];
      s = n;
      chain.push_back(e);
    }
    // backward from the first edge
    std::vector<std::size_t> head;
    for (std::size_t s = s0, e = segs[s0][0];;) {
      const std::size_t n = other_segment(e, s);
      if (n == none || used[n]) break;
      used[n] = 1;
      e = segs[n][0] == e ? segs[n][1] : segs[n][0];
      s = n;
      head.push_back(e);
    }
    std::vector<P2> line;
    line.reserve(head.size() + chain.size());
    for (auto it = head.rbegin(); it != head.rend(); ++it) line.push_back(point[*it]);
    for (std::size_t e : chain) line.push_back(point[e]);
    lines.push_back(std::move(line));
  }
  return lines;
}

}  // namespace pvdf::plot
