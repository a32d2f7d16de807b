// Drawing a panel with Cairo: fields as colour images, lines, markers, polygons, labelled
// contours, frame and ticks, legend and colour bar. Cairo does the anti-aliasing, stroking and
// clipping; geometry far outside the panel is cut first so that huge data values cannot overflow
// Cairo's fixed-point coordinates.
#include "draw.hpp"

#include "interpolate.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>

namespace pvdf::plot::detail {
namespace {

const Color kBlack{0, 0, 0}, kWhite{255, 255, 255}, kFrame{40, 40, 40}, kGrid{222, 222, 222};

double pixel_center(double p) { return std::floor(p) + 0.5; }

struct LegendEntry {
  std::string label;
  Color color;
  LineStyle style = LineStyle::solid;
  Marker marker = Marker::none;
  double width = 2, marker_size = 6;
  bool patch = false;
  std::optional<Color> fill, edge;
};

std::vector<LegendEntry> legend_entries(const Axes::Impl& a) {
  std::vector<LegendEntry> out;
  for (const auto& it : a.items) {
    if (!has_legend_entry(it)) continue;
    LegendEntry e;
    e.label = it.label;
    e.color = it.color;
    switch (it.kind) {
      case Kind::line: e.style = it.style, e.marker = it.marker, e.width = it.width, e.marker_size = it.size; break;
      case Kind::scatter: e.style = LineStyle::none, e.marker = it.marker, e.marker_size = it.size; break;
      case Kind::contour:
      case Kind::hline:
      case Kind::vline: e.style = it.style, e.width = it.width; break;
      case Kind::polygon: e.patch = true, e.fill = it.fill, e.edge = it.edge; break;
      default: continue;
    }
    out.push_back(e);
  }
  return out;
}

bool inside(const P2& p, const std::array<double, 4>& b) {
  return p[0] >= b[0] && p[0] <= b[2] && p[1] >= b[1] && p[1] <= b[3];
}

/// Liang–Barsky: the parameter interval [t0, t1] of segment a→b inside box b; false if none.
bool clip_segment(const P2& a, const P2& c, const std::array<double, 4>& box, double& t0, double& t1) {
  const double dx = c[0] - a[0], dy = c[1] - a[1];
  const double p[4] = {-dx, dx, -dy, dy};
  const double q[4] = {a[0] - box[0], box[2] - a[0], a[1] - box[1], box[3] - a[1]};
  t0 = 0, t1 = 1;
  for (int k = 0; k < 4; ++k) {
    if (p[k] == 0) {
      if (q[k] < 0) return false;
      continue;
    }
    const double r = q[k] / p[k];
    if (p[k] < 0) t0 = std::max(t0, r);
    else t1 = std::min(t1, r);
    if (t0 > t1) return false;
  }
  return true;
}

/// The pieces of a polyline inside `box`.
std::vector<std::vector<P2>> clip_polyline(const std::vector<P2>& pts, const std::array<double, 4>& box) {
  if (std::all_of(pts.begin(), pts.end(), [&](const P2& p) { return inside(p, box); })) return {pts};
  std::vector<std::vector<P2>> out;
  std::vector<P2> cur;
  auto flush = [&] {
    if (cur.size() >= 2) out.push_back(cur);
    cur.clear();
  };
  for (std::size_t i = 1; i < pts.size(); ++i) {
    const P2 a = pts[i - 1], c = pts[i];
    double t0 = 0, t1 = 1;
    if (!clip_segment(a, c, box, t0, t1)) {
      flush();
      continue;
    }
    if (cur.empty() || t0 > 0) {
      flush();
      cur.push_back({a[0] + t0 * (c[0] - a[0]), a[1] + t0 * (c[1] - a[1])});
    }
    cur.push_back({a[0] + t1 * (c[0] - a[0]), a[1] + t1 * (c[1] - a[1])});
    if (t1 < 1) flush();
  }
  flush();
  return out;
}

/// Sutherland–Hodgman: the part of a polygon inside `box` (only needed for far-out vertices).
std::vector<P2> clip_polygon(std::vector<P2> poly, const std::array<double, 4>& box) {
  for (int edge = 0; edge < 4 && !poly.empty(); ++edge) {
    const int axis = edge % 2;
    const bool upper = edge >= 2;
    const double bound = box[edge];
    auto in = [&](const P2& p) { return upper ? p[axis] <= bound : p[axis] >= bound; };
    std::vector<P2> out;
    for (std::size_t i = 0; i < poly.size(); ++i) {
      const P2 a = poly[i], b = poly[(i + 1) % poly.size()];
      if (in(a)) out.push_back(a);
      if (in(a) != in(b)) {
        const double t = (bound - a[axis]) / (b[axis] - a[axis]);
        out.push_back({a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1])});
      }
    }
    poly = std::move(out);
  }
  return poly;
}

std::vector<double> cumulative_length(const std::vector<P2>& q) {
  std::vector<double> cum(q.size(), 0.0);
  for (std::size_t i = 1; i < q.size(); ++i) cum[i] = cum[i - 1] + std::hypot(q[i][0] - q[i - 1][0], q[i][1] - q[i - 1][1]);
  return cum;
}

P2 point_at(const std::vector<P2>& q, const std::vector<double>& cum, double s) {
  s = std::clamp(s, 0.0, cum.back());
  const std::size_t k = std::min<std::size_t>(
      static_cast<std::size_t>(std::upper_bound(cum.begin(), cum.end(), s) - cum.begin()), q.size() - 1);
  const std::size_t i = std::max<std::size_t>(k, 1);
  const double len = cum[i] - cum[i - 1];
  const double t = len > 0 ? (s - cum[i - 1]) / len : 0;
  return {q[i - 1][0] + t * (q[i][0] - q[i - 1][0]), q[i - 1][1] + t * (q[i][1] - q[i - 1][1])};
}

/// The parts of polyline q (arc length `cum`) within the arc-length intervals `keep`.
std::vector<std::vector<P2>> cut_polyline(const std::vector<P2>& q, const std::vector<double>& cum,
                                          const std::vector<std::pair<double, double>>& keep) {
  std::vector<std::vector<P2>> out;
  for (const auto& [s0, s1] : keep) {
    if (!(s1 > s0)) continue;
    std::vector<P2> run{point_at(q, cum, s0)};
    for (std::size_t i = 0; i < q.size(); ++i)
      if (cum[i] > s0 && cum[i] < s1) run.push_back(q[i]);
    run.push_back(point_at(q, cum, s1));
    out.push_back(std::move(run));
  }
  return out;
}

/// Points every few pixels along a polyline, so that "best" legend placement avoids lines
/// between sparse data points too.
void sample_polyline(const std::vector<P2>& run, std::vector<P2>& pts) {
  if (run.empty()) return;
  pts.push_back(run[0]);
  for (std::size_t i = 1; i < run.size(); ++i) {
    const double len = std::hypot(run[i][0] - run[i - 1][0], run[i][1] - run[i - 1][1]);
    const int n = std::min(2000, static_cast<int>(len / 6));
    for (int k = 1; k <= n; ++k) {
      const double t = static_cast<double>(k) / (n + 1);
      pts.push_back({run[i - 1][0] + t * (run[i][0] - run[i - 1][0]), run[i - 1][1] + t * (run[i][1] - run[i - 1][1])});
    }
    pts.push_back(run[i]);
  }
}

std::vector<std::vector<P2>> to_pixels(const std::vector<double>& x, const std::vector<double>& y, const PanelLayout& p) {
  std::vector<std::vector<P2>> runs(1);
  for (std::size_t i = 0; i < x.size(); ++i) {
    const P2 q{p.xs.to_px(x[i]), p.ys.to_px(y[i])};
    if (!finite(q[0]) || !finite(q[1])) {
      if (!runs.back().empty()) runs.emplace_back();
      continue;
    }
    runs.back().push_back(q);
  }
  return runs;
}

}  // namespace

// ---------------------------------------------------------------------------------------------
// Primitives.

void PanelPainter::set_color(Color c) { cairo_set_source_rgb(cr_, c.r / 255.0, c.g / 255.0, c.b / 255.0); }

void PanelPainter::stroke_polyline(const std::vector<P2>& pts, double width, Color c, LineStyle style, bool closed) {
  if (style == LineStyle::none || pts.size() < 2) return;
  std::vector<P2> loop = pts;
  if (closed) loop.push_back(pts.front());
  const bool all_inside = std::all_of(loop.begin(), loop.end(), [&](const P2& p) { return inside(p, clip_box_); });
  cairo_save(cr_);
  set_color(c);
  cairo_set_line_width(cr_, width);
  cairo_set_line_join(cr_, CAIRO_LINE_JOIN_ROUND);
  cairo_set_line_cap(cr_, style == LineStyle::dashed ? CAIRO_LINE_CAP_BUTT : CAIRO_LINE_CAP_ROUND);
  if (style == LineStyle::dashed) {
    const double dash[2] = {std::max(6.0, 3.5 * width), std::max(4.0, 2.5 * width)};
    cairo_set_dash(cr_, dash, 2, 0);
  } else if (style == LineStyle::dotted) {
    const double dash[2] = {0.0, std::max(3.0, 2.2 * width)};
    cairo_set_dash(cr_, dash, 2, 0);
  }
  for (const auto& run : all_inside ? std::vector<std::vector<P2>>{loop} : clip_polyline(loop, clip_box_)) {
    cairo_move_to(cr_, run[0][0], run[0][1]);
    for (std::size_t i = 1; i < run.size(); ++i) cairo_line_to(cr_, run[i][0], run[i][1]);
    if (closed && all_inside) cairo_close_path(cr_);
    cairo_stroke(cr_);
  }
  cairo_restore(cr_);
}

void PanelPainter::segment(P2 a, P2 b, double width, Color c) { stroke_polyline({a, b}, width, c, LineStyle::solid); }

void PanelPainter::fill_polygon(const std::vector<P2>& pts, Color c) {
  if (pts.size() < 3) return;
  const bool all_inside = std::all_of(pts.begin(), pts.end(), [&](const P2& p) { return inside(p, clip_box_); });
  const std::vector<P2> poly = all_inside ? pts : clip_polygon(pts, clip_box_);
  if (poly.size() < 3) return;
  set_color(c);
  cairo_move_to(cr_, poly[0][0], poly[0][1]);
  for (std::size_t i = 1; i < poly.size(); ++i) cairo_line_to(cr_, poly[i][0], poly[i][1]);
  cairo_close_path(cr_);
  cairo_fill(cr_);
}

void PanelPainter::marker(P2 q, Marker m, double size, Color c) {
  if (m == Marker::none || !finite(q[0]) || !finite(q[1]) || !inside(q, clip_box_)) return;
  const double r = size / 2;
  switch (m) {
    case Marker::circle:
      set_color(c);
      cairo_new_sub_path(cr_);
      cairo_arc(cr_, q[0], q[1], r, 0, 2 * kPi);
      cairo_fill(cr_);
      break;
    case Marker::square: fill_polygon({{q[0] - r, q[1] - r}, {q[0] + r, q[1] - r}, {q[0] + r, q[1] + r}, {q[0] - r, q[1] + r}}, c); break;
    case Marker::triangle:
      fill_polygon({{q[0], q[1] - 1.15 * r}, {q[0] + r, q[1] + 0.75 * r}, {q[0] - r, q[1] + 0.75 * r}}, c);
      break;
    case Marker::cross: {
      const double w = std::max(1.5, size / 6);
      segment({q[0] - r, q[1] - r}, {q[0] + r, q[1] + r}, w, c);
      segment({q[0] - r, q[1] + r}, {q[0] + r, q[1] - r}, w, c);
      break;
    }
    case Marker::plus: {
      const double w = std::max(1.5, size / 6);
      segment({q[0] - r, q[1]}, {q[0] + r, q[1]}, w, c);
      segment({q[0], q[1] - r}, {q[0], q[1] + r}, w, c);
      break;
    }
    case Marker::none: break;
  }
}

// ---------------------------------------------------------------------------------------------
// Panel content.

void PanelPainter::draw_panel(const Axes::Impl& a, const PanelLayout& p) {
  const double L = p.L, R = p.R, T = p.T, B = p.B;
  clip_box_ = {L - 1000, T - 1000, R + 1000, B + 1000};
  placed_labels_.clear();
  std::vector<P2> data_points;  // for legend placement
  // Contour labels keep clear of small filled polygons (electrodes) and text annotations.
  const bool labelled_contours = std::any_of(a.items.begin(), a.items.end(),
                                             [](const Item& it) { return it.kind == Kind::contour && !it.format.empty(); });
  line_points_.clear();
  line_counter_ = 0;
  std::size_t line_id = 0;
  for (const auto& it : a.items) {
    if (!labelled_contours) break;
    if (it.kind == Kind::contour) {
      // Labels also keep clear of the other contour lines (sampled densely enough that a line
      // cannot cross a label box between two samples).
      for (const auto& level : it.contours) {
        for (const auto& line : level) {
          std::vector<P2> run;
          for (const auto& v : line) run.push_back({p.xs.to_px(v[0]), p.ys.to_px(v[1])});
          std::vector<P2> dense;
          if (run.size() >= 2 && std::all_of(run.begin(), run.end(), [](const P2& q) { return finite(q[0]) && finite(q[1]); })) {
            for (std::size_t i = 1; i < run.size(); ++i) {
              const int n = std::min(1000, 1 + static_cast<int>(std::hypot(run[i][0] - run[i - 1][0], run[i][1] - run[i - 1][1]) / 3));
              for (int k = 0; k < n; ++k) {
                const double t = static_cast<double>(k) / n;
                line_points_.push_back({run[i - 1][0] + t * (run[i][0] - run[i - 1][0]),
                                        run[i - 1][1] + t * (run[i][1] - run[i - 1][1]), line_id});
              }
            }
          }
          ++line_id;
        }
      }
      continue;
    }
    if (it.kind == Kind::polygon && it.fill && !it.vertices.empty()) {
      double x0 = 1e300, x1 = -1e300, y0 = 1e300, y1 = -1e300;
      for (const auto& v : it.vertices) {
        const double x = p.xs.to_px(v[0]), y = p.ys.to_px(v[1]);
        x0 = std::min(x0, x), x1 = std::max(x1, x), y0 = std::min(y0, y), y1 = std::max(y1, y);
      }
      if (finite(x0) && finite(y0) && (x1 - x0) * (y1 - y0) < 0.05 * (R - L) * (B - T))
        placed_labels_.push_back({(x0 + x1) / 2, (y0 + y1) / 2, (x1 - x0) / 2, (y1 - y0) / 2});
    } else if (it.kind == Kind::scatter && it.x.size() <= 200) {
      for (std::size_t i = 0; i < it.x.size(); ++i)
        placed_labels_.push_back({p.xs.to_px(it.x[i]), p.ys.to_px(it.y[i]), it.size / 2 + 2, it.size / 2 + 2});
    } else if (it.kind == Kind::text) {
      const double x = p.xs.to_px(it.x[0]), y = p.ys.to_px(it.y[0]), w = text_.width(it.label, it.font_px);
      if (finite(x) && finite(y)) placed_labels_.push_back({x + w / 2, y - it.font_px * 0.4, w / 2, it.font_px * 0.5});
    }
  }
  cairo_save(cr_);
  cairo_rectangle(cr_, L, T, R - L, B - T);
  cairo_clip(cr_);
  for (const auto& it : a.items)
    if (it.kind == Kind::field) draw_field(it, p, a.log_color, a.domain, a.domain_inset);
  if (a.grid) {
    for (const auto& t : p.xt)
      if (t.major) segment({pixel_center(p.xs.to_px(t.value)), T}, {pixel_center(p.xs.to_px(t.value)), B}, 1, kGrid);
    for (const auto& t : p.yt)
      if (t.major) segment({L, pixel_center(p.ys.to_px(t.value))}, {R, pixel_center(p.ys.to_px(t.value))}, 1, kGrid);
  }
  for (const auto& it : a.items) {
    switch (it.kind) {
      case Kind::line: draw_line(it, p, data_points); break;
      case Kind::scatter:
        for (std::size_t i = 0; i < it.x.size(); ++i) {
          const P2 q{p.xs.to_px(it.x[i]), p.ys.to_px(it.y[i])};
          marker(q, it.marker, it.size, it.color);
          if (finite(q[0]) && finite(q[1])) data_points.push_back(q);
        }
        break;
      case Kind::error_bars: draw_error_bars(it, p, data_points); break;
      case Kind::contour: draw_contour(it, p, data_points); break;
      case Kind::polygon: draw_polygon(it, p, data_points); break;
      case Kind::hline:
      case Kind::vline: {
        const bool h = it.kind == Kind::hline;
        const double v = h ? p.ys.to_px(it.y[0]) : p.xs.to_px(it.x[0]);
        if (!finite(v)) break;
        const std::vector<P2> run = h ? std::vector<P2>{{L, v}, {R, v}} : std::vector<P2>{{v, T}, {v, B}};
        stroke_polyline(run, it.width, it.color, it.style);
        sample_polyline(run, data_points);
        break;
      }
      case Kind::text: {
        const double x = p.xs.to_px(it.x[0]), y = p.ys.to_px(it.y[0]);
        if (finite(x) && finite(y) && x >= L && x <= R && y >= T && y <= B)
          text_.draw(x, y, it.label, it.font_px, it.color);
        break;
      }
      case Kind::field: break;
    }
  }
  // Contour labels on top of everything drawn in the panel (markers, electrodes).
  for (const auto& l : pending_labels_) text_.draw(l.x, l.y, l.text, kContourPx, l.color, l.angle_deg, 0.5, VAlign::center);
  pending_labels_.clear();
  cairo_restore(cr_);
  draw_frame_and_ticks(a, p);
  if (p.cbar.on) draw_colorbar(p.cbar);
  draw_legend(a, p, data_points);
}

namespace {

/// Signed distance from (x, y) to the closed polygon `v` (positive inside, even–odd rule).
double signed_distance(const std::vector<P2>& v, double x, double y) {
  double d2 = std::numeric_limits<double>::infinity();
  bool inside = false;
  for (std::size_t i = 0, j = v.size() - 1; i < v.size(); j = i++) {
    const double ax = v[j][0], ay = v[j][1], ex = v[i][0] - ax, ey = v[i][1] - ay;
    const double len2 = ex * ex + ey * ey;
    const double t = len2 > 0 ? std::clamp(((x - ax) * ex + (y - ay) * ey) / len2, 0.0, 1.0) : 0.0;
    const double dx = x - ax - t * ex, dy = y - ay - t * ey;
    d2 = std::min(d2, dx * dx + dy * dy);
    if ((v[i][1] > y) != (v[j][1] > y) && x < ax + (y - ay) * ex / ey) inside = !inside;
  }
  return inside ? std::sqrt(d2) : -std::sqrt(d2);
}

/// One ring of extrapolation: every NaN node with a finite 8-neighbour takes their mean.
void extend_one_ring(Grid& g) {
  const std::vector<double> original = g.values;
  for (std::size_t j = 0; j < g.ny; ++j) {
    for (std::size_t i = 0; i < g.nx; ++i) {
      if (!std::isnan(original[j * g.nx + i])) continue;
      double sum = 0;
      int n = 0;
      for (long dj = -1; dj <= 1; ++dj) {
        for (long di = -1; di <= 1; ++di) {
          const long ii = long(i) + di, jj = long(j) + dj;
          if (ii < 0 || jj < 0 || ii >= long(g.nx) || jj >= long(g.ny)) continue;
          const double v = original[std::size_t(jj) * g.nx + std::size_t(ii)];
          if (std::isfinite(v)) sum += v, ++n;
        }
      }
      if (n > 0) g.values[j * g.nx + i] = sum / n;
    }
  }
}

}  // namespace

void PanelPainter::draw_field(const Item& it, const PanelLayout& p, bool log, const std::vector<P2>& domain,
                              double inset) {
  const Grid& g = *it.grid;
  if (g.nx < 2 || g.ny < 2 || !(g.x1 != g.x0) || !(g.y1 != g.y0)) return;
  const auto range = field_range(it, log);
  const double lo = log ? std::log10(range[0]) : range[0];
  const double inv = 1.0 / ((log ? std::log10(range[1]) : range[1]) - lo);
  const int W = static_cast<int>(p.R - p.L), H = static_cast<int>(p.B - p.T);
  if (W <= 0 || H <= 0) return;
  // One image pixel per PNG pixel of the plot rectangle, on the grid's smooth interpolant (the
  // one contours are traced on); NaN → transparent.
  static constexpr int kLut = 1024;
  std::vector<std::uint32_t> lut(kLut);
  for (int k = 0; k < kLut; ++k) {
    const Color c = it.diverging ? colormap_diverging(k / (kLut - 1.0)) : colormap(k / (kLut - 1.0));
    lut[static_cast<std::size_t>(k)] = 0xFF000000u | (std::uint32_t(c.r) << 16) | (std::uint32_t(c.g) << 8) | c.b;
  }
  cairo_surface_t* img = cairo_image_surface_create(CAIRO_FORMAT_ARGB32, W, H);
  cairo_surface_flush(img);
  unsigned char* data = cairo_image_surface_get_data(img);
  const int stride = cairo_image_surface_get_stride(img);
  // A log colour scale interpolates log10 of the values: a smooth interpolant of values spanning
  // decades overshoots below zero next to large ones (dark blots), its logarithm does not. Values
  // <= 0 and +inf stand one decade beyond the scale (the end colours).
  Grid logged;
  const Grid* source = &g;
  if (log) {
    logged = g;
    const double hi = std::log10(range[1]);
    for (double& v : logged.values) {
      if (std::isnan(v)) continue;
      v = v > 0 ? std::log10(v) : lo - 1;
      if (!std::isfinite(v)) v = hi + 1;
    }
    source = &logged;
  }
  Grid extended;
  if (domain.size() >= 3) {
    extended = *source;
    extend_one_ring(extended);
    source = &extended;
  }
  // Data units per pixel, for the anti-aliased edge of the domain (a one-pixel ramp of coverage).
  const double unit_per_px = std::max(std::abs(p.xs.from_px(p.L + 1) - p.xs.from_px(p.L)),
                                      std::abs(p.ys.from_px(p.T + 1) - p.ys.from_px(p.T)));
  const double nxm = static_cast<double>(g.nx - 1), nym = static_cast<double>(g.ny - 1);
  std::vector<double> fi(static_cast<std::size_t>(W));
  for (int i = 0; i < W; ++i) fi[static_cast<std::size_t>(i)] = (p.xs.from_px(p.L + i + 0.5) - g.x0) / (g.x1 - g.x0) * nxm;
  for (int j = 0; j < H; ++j) {
    auto* row = reinterpret_cast<std::uint32_t*>(data + static_cast<std::ptrdiff_t>(j) * stride);
    const double b = (p.ys.from_px(p.T + j + 0.5) - g.y0) / (g.y1 - g.y0) * nym;
    for (int i = 0; i < W; ++i) {
      row[i] = 0;
      const double f = interpolate_field(*source, fi[static_cast<std::size_t>(i)], b);
      if (std::isnan(f)) continue;
      const double t = std::clamp((f - lo) * inv, 0.0, 1.0);
      const std::uint32_t c = lut[static_cast<std::size_t>(t * (kLut - 1) + 0.5)];
      if (domain.size() < 3) {
        row[i] = c;
        continue;
      }
      const double d = signed_distance(domain, p.xs.from_px(p.L + i + 0.5), p.ys.from_px(p.T + j + 0.5)) - inset;
      const double cover = std::clamp(d / unit_per_px + 0.5, 0.0, 1.0);
      if (cover <= 0) continue;
      // Cairo's ARGB32 is premultiplied by alpha.
      const auto scaled = [cover](std::uint32_t v) { return std::uint32_t(double(v & 0xFFu) * cover + 0.5); };
      row[i] = (scaled(0xFFu) << 24) | (scaled(c >> 16) << 16) | (scaled(c >> 8) << 8) | scaled(c);
    }
  }
  cairo_surface_mark_dirty(img);
  cairo_set_source_surface(cr_, img, p.L, p.T);
  cairo_pattern_set_filter(cairo_get_source(cr_), CAIRO_FILTER_NEAREST);
  cairo_paint(cr_);
  cairo_surface_destroy(img);
}

void PanelPainter::draw_line(const Item& it, const PanelLayout& p, std::vector<P2>& pts) {
  for (const auto& run : to_pixels(it.x, it.y, p)) {
    if (run.empty()) continue;
    if (run.size() == 1 && it.marker == Marker::none && it.style != LineStyle::none)
      marker(run[0], Marker::circle, 2 * it.width, it.color);  // a lone point stays visible
    stroke_polyline(run, it.width, it.color, it.style);
    for (const auto& q : run) marker(q, it.marker, it.size, it.color);
    if (it.style == LineStyle::none) pts.insert(pts.end(), run.begin(), run.end());
    else sample_polyline(run, pts);
  }
}

void PanelPainter::draw_error_bars(const Item& it, const PanelLayout& p, std::vector<P2>& pts) {
  for (std::size_t i = 0; i < it.x.size(); ++i) {
    const double e = std::abs(it.err[i]);
    const double x = p.xs.to_px(it.x[i]);
    const double y0 = p.ys.to_px(it.y[i] - e), y1 = p.ys.to_px(it.y[i] + e);
    if (!finite(x) || !finite(y1)) continue;
    const double lo = finite(y0) ? y0 : p.B + 10.0;
    segment({x, lo}, {x, y1}, 1.3, it.color);
    segment({x - 4, lo}, {x + 4, lo}, 1.3, it.color);
    segment({x - 4, y1}, {x + 4, y1}, 1.3, it.color);
    pts.push_back({x, lo});
    pts.push_back({x, y1});
  }
}

void PanelPainter::draw_polygon(const Item& it, const PanelLayout& p, std::vector<P2>& pts) {
  std::vector<P2> q;
  q.reserve(it.vertices.size());
  for (const auto& v : it.vertices) {
    const P2 a{p.xs.to_px(v[0]), p.ys.to_px(v[1])};
    if (!finite(a[0]) || !finite(a[1])) return;
    q.push_back(a);
  }
  if (q.empty()) return;
  if (it.fill) fill_polygon(q, *it.fill);
  if (it.edge && it.width > 0) stroke_polyline(q, it.width, *it.edge, LineStyle::solid, true);
  if (!it.label.empty() || pts.size() < 4096) pts.push_back(q[0]);
}

void PanelPainter::draw_contour(const Item& it, const PanelLayout& p, std::vector<P2>& pts) {
  for (std::size_t l = 0; l < it.levels.size(); ++l) {
    std::string label;
    if (!it.format.empty()) {
      char buf[128];
      std::snprintf(buf, sizeof buf, it.format.c_str(), it.levels[l] * it.scale);
      label = with_minus_sign(buf);
    }
    const double tw = label.empty() ? 0 : text_.width(label, kContourPx);
    for (const auto& line : it.contours[l]) {
      const std::size_t this_line = line_counter_++;
      std::vector<P2> q;
      for (const auto& v : line) {
        const P2 a{p.xs.to_px(v[0]), p.ys.to_px(v[1])};
        if (finite(a[0]) && finite(a[1])) q.push_back(a);
      }
      if (q.size() < 2) continue;
      for (std::size_t k = 0; k < q.size(); k += 8) pts.push_back(q[k]);
      const auto cum = cumulative_length(q);
      const double total = cum.back();
      std::vector<std::pair<double, double>> gaps;  // arc-length intervals under labels
      // One label per ~350 px of line. In each stretch, the first position whose label box is
      // inside the panel and clear of every label already placed in this panel (of any
      // contour family).
      const int n_labels = label.empty() || !(total > 2.5 * tw + 20) ? 0 : std::max(1, static_cast<int>(total / 350));
      for (int n = 0; n < n_labels; ++n) {
        const double s0 = total * n / n_labels, len = total / n_labels;
        for (double frac : {0.5, 0.3, 0.7, 0.15, 0.85, 0.4, 0.6, 0.22, 0.78, 0.08, 0.92}) {
          const double s = s0 + frac * len;
          if (s - tw / 2 - 4 < 0 || s + tw / 2 + 4 > total) continue;
          const P2 c = point_at(q, cum, s);
          const P2 a = point_at(q, cum, s - tw / 2), b = point_at(q, cum, s + tw / 2);
          if (c[0] < p.L + tw / 2 + 2 || c[0] > p.R - tw / 2 - 2 || c[1] < p.T + 8 || c[1] > p.B - 8) continue;
          bool clash = false;
          for (const auto& o : placed_labels_)
            if (std::abs(o[0] - c[0]) < o[2] + tw / 2 + 6 && std::abs(o[1] - c[1]) < o[3] + kContourPx) clash = true;
          if (clash) continue;
          double angle = std::atan2(-(b[1] - a[1]), b[0] - a[0]) * 180 / kPi;
          if (angle > 90) angle -= 180;
          if (angle < -90) angle += 180;
          // No other contour line through the label (tested in the label's own frame).
          const double ca0 = std::cos(angle * kPi / 180), sa0 = std::sin(angle * kPi / 180);
          for (const auto& lp : line_points_) {
            if (lp.line == this_line) continue;
            const double dx = lp.x - c[0], dy = lp.y - c[1];
            const double along = dx * ca0 - dy * sa0, across = dx * sa0 + dy * ca0;
            if (std::abs(along) < tw / 2 + 2 && std::abs(across) < kContourPx * 0.6) {
              clash = true;
              break;
            }
          }
          if (clash) continue;
          pending_labels_.push_back({c[0], c[1], label, it.color, angle});
          // The box of a rotated label, for the clash test.
          const double ca = std::abs(std::cos(angle * kPi / 180)), sa = std::abs(std::sin(angle * kPi / 180));
          placed_labels_.push_back({c[0], c[1], (tw * ca + kContourPx * sa) / 2, (tw * sa + kContourPx * ca) / 2});
          gaps.push_back({s - tw / 2 - 4, s + tw / 2 + 4});
          break;
        }
      }
      std::vector<std::pair<double, double>> keep;
      double from = 0;
      for (const auto& g : gaps) keep.push_back({from, g.first}), from = g.second;
      keep.push_back({from, total});
      const bool closed = std::hypot(q.front()[0] - q.back()[0], q.front()[1] - q.back()[1]) < 1e-6;
      if (keep.size() == 1) {
        stroke_polyline(q, it.width, it.color, it.style, closed);
      } else {
        for (const auto& run : cut_polyline(q, cum, keep)) stroke_polyline(run, it.width, it.color, it.style);
      }
    }
  }
}

// ---------------------------------------------------------------------------------------------
// Frame, ticks, colour bar, legend.

void PanelPainter::draw_frame_and_ticks(const Axes::Impl& a, const PanelLayout& p) {
  const double L = p.L, R = p.R, T = p.T, B = p.B;
  clip_box_ = {-1e5, -1e5, 1e5, 1e5};
  // Frame: one-pixel lines just outside the plot rectangle.
  set_color(kFrame);
  cairo_set_line_width(cr_, 1);
  cairo_rectangle(cr_, L - 0.5, T - 0.5, R - L + 1, B - T + 1);
  cairo_stroke(cr_);
  for (const auto& t : p.xt) {
    const double x = pixel_center(p.xs.to_px(t.value));
    if (!finite(x) || x < L - 1 || x > R + 1) continue;
    const double len = t.major ? kTickLen : kTickLen * 0.6;
    segment({x, B + 1}, {x, B + 1 + len}, 1, kFrame);
    if (t.major && !t.label.empty()) text_.draw(x, B + kTickLen + 5, t.label, kTickPx, kBlack, 0, 0.5, VAlign::top);
  }
  for (const auto& t : p.yt) {
    const double y = pixel_center(p.ys.to_px(t.value));
    if (!finite(y) || y < T - 1 || y > B + 1) continue;
    const double len = t.major ? kTickLen : kTickLen * 0.6;
    segment({L - 1 - len, y}, {L - 1, y}, 1, kFrame);
    if (t.major && !t.label.empty()) text_.draw(L - kTickLen - 5, y, t.label, kTickPx, kBlack, 0, 1, VAlign::center);
  }
  if (!a.xlabel.empty()) text_.draw((L + R) / 2, B + kTickLen + 5 + kTickPx + 9, a.xlabel, kLabelPx, kBlack, 0, 0.5, VAlign::top);
  if (!p.xmult.empty()) text_.draw(R, B + kTickLen + 5 + kTickPx + 9, p.xmult, kTickPx, kBlack, 0, 1, VAlign::top);
  if (!p.ymult.empty()) text_.draw(L, T - 6, p.ymult, kTickPx, kBlack, 0, 0, VAlign::bottom);
  if (!a.ylabel.empty())
    text_.draw(L - kTickLen - 5 - p.ytick_w - 9, (T + B) / 2, a.ylabel, kLabelPx, kBlack, 90, 0.5, VAlign::bottom);
  if (!a.title.empty()) text_.draw((L + R) / 2, T - 9, a.title, kTitlePx, kBlack, 0, 0.5, VAlign::bottom);
}

void PanelPainter::draw_colorbar(const ColorBar& cb) {
  const double tri = cb.R - cb.L;  // height of an extend triangle
  const double top = cb.T + (cb.extend_hi ? tri : 0), bottom = cb.B - (cb.extend_lo ? tri : 0);
  Scale s = cb.scale;
  s.lo = cb.vmin, s.hi = cb.vmax, s.p0 = bottom, s.p1 = top;
  auto cmap = [&](double t) { return cb.diverging ? colormap_diverging(t) : colormap(t); };
  cairo_pattern_t* grad = cairo_pattern_create_linear(0, bottom, 0, top);
  for (int k = 0; k <= 64; ++k) {
    const Color c = cmap(k / 64.0);
    cairo_pattern_add_color_stop_rgb(grad, k / 64.0, c.r / 255.0, c.g / 255.0, c.b / 255.0);
  }
  cairo_rectangle(cr_, cb.L, top, cb.R - cb.L, bottom - top);
  cairo_set_source(cr_, grad);
  cairo_fill(cr_);
  cairo_pattern_destroy(grad);
  const double mid = (cb.L + cb.R) / 2;
  if (cb.extend_hi) fill_polygon({{cb.L, top}, {cb.R, top}, {mid, cb.T}}, cmap(1));
  if (cb.extend_lo) fill_polygon({{cb.L, bottom}, {cb.R, bottom}, {mid, cb.B}}, cmap(0));
  // Contour levels of the panel, marked across the bar in their colour.
  if (cb.panel) {
    for (const auto& it : cb.panel->items) {
      if (it.kind != Kind::contour) continue;
      for (double level : it.levels) {
        const double y = s.to_px(level);
        if (finite(y) && y >= top && y <= bottom) segment({cb.L, y}, {cb.R, y}, 1.2, it.color);
      }
    }
  }
  // Outline: the bar with its triangles.
  cairo_move_to(cr_, cb.L - 0.5, bottom);
  cairo_line_to(cr_, cb.L - 0.5, top);
  if (cb.extend_hi) cairo_line_to(cr_, mid, cb.T - 0.5);
  else cairo_line_to(cr_, cb.L - 0.5, top - 0.5), cairo_line_to(cr_, cb.R + 0.5, top - 0.5);
  cairo_line_to(cr_, cb.R + 0.5, top);
  cairo_line_to(cr_, cb.R + 0.5, bottom);
  if (cb.extend_lo) cairo_line_to(cr_, mid, cb.B + 0.5);
  else cairo_line_to(cr_, cb.R + 0.5, bottom + 0.5), cairo_line_to(cr_, cb.L - 0.5, bottom + 0.5);
  cairo_close_path(cr_);
  set_color(kFrame);
  cairo_set_line_width(cr_, 1);
  cairo_set_line_join(cr_, CAIRO_LINE_JOIN_MITER);
  cairo_stroke(cr_);
  double w = 0;
  for (const auto& t : cb.ticks) {
    const double y = pixel_center(s.to_px(t.value));
    if (!finite(y) || y < top - 1 || y > bottom + 1) continue;
    segment({cb.R + 1.0, y}, {cb.R + 1 + kTickLen, y}, 1, kFrame);
    text_.draw(cb.R + kTickLen + 5, y, t.label, kTickPx, kBlack, 0, 0, VAlign::center);
    w = std::max(w, text_.width(t.label, kTickPx));
  }
  if (!cb.mult.empty()) text_.draw(cb.L, cb.T - 6, cb.mult, kTickPx, kBlack, 0, 0, VAlign::bottom);
  if (!cb.label.empty())
    text_.draw(cb.R + kTickLen + 5 + w + 9, (cb.T + cb.B) / 2, cb.label, kLabelPx, kBlack, 90, 0.5, VAlign::top);
}

void PanelPainter::draw_legend(const Axes::Impl& a, const PanelLayout& p, const std::vector<P2>& data_points) {
  if (p.legend == "none") return;
  const auto entries = legend_entries(a);
  if (entries.empty()) return;
  const double row = kLegendPx * 1.5, inset = 8;
  double x0 = 0, y0 = 0, bw = 0, bh = 0;
  std::vector<std::array<double, 2>> entry_xy;
  if (p.legend == "outside right" || p.legend == "outside below") {
    x0 = p.legend_x0, y0 = p.legend_y0, bw = p.legend_w, bh = p.legend_h;
    entry_xy = p.legend_entry_xy;
  } else {
    double tw = 0;
    for (const auto& e : entries) tw = std::max(tw, text_.width(e.label, kLegendPx));
    bw = kLegendPad + kLegendHandle + kLegendGap + tw + kLegendPad;
    bh = kLegendPad + row * static_cast<double>(entries.size()) + kLegendPad - 4;
    for (std::size_t k = 0; k < entries.size(); ++k) entry_xy.push_back({kLegendPad, kLegendPad + row * static_cast<double>(k)});
    // "best" tries the corners first (ties keep this order), then the edge centres.
    const char* const order[] = {"upper right",  "upper left",  "lower left",   "lower right",
                                 "center right", "center left", "upper center", "lower center"};
    std::string where = p.legend;
    auto box_at = [&](const std::string& w) {
      const bool left = w.find("left") != std::string::npos, right = w.find("right") != std::string::npos;
      const bool upper = w.find("upper") != std::string::npos, lower = w.find("lower") != std::string::npos;
      const double bx = left ? p.L + inset : right ? p.R - inset - bw : (p.L + p.R - bw) / 2;
      const double by = upper ? p.T + inset : lower ? p.B - inset - bh : (p.T + p.B - bh) / 2;
      return std::array<double, 2>{bx, by};
    };
    if (where == "best") {
      std::size_t best_count = std::numeric_limits<std::size_t>::max();
      for (const char* w : order) {
        const auto b = box_at(w);
        std::size_t n = 0;
        for (const auto& q : data_points)
          if (q[0] >= b[0] - 4 && q[0] <= b[0] + bw + 4 && q[1] >= b[1] - 4 && q[1] <= b[1] + bh + 4) ++n;
        if (n < best_count) best_count = n, where = w;
      }
    }
    const auto b = box_at(where);
    x0 = std::round(b[0]), y0 = std::round(b[1]);
  }
  if (entry_xy.size() != entries.size()) return;
  cairo_rectangle(cr_, x0 + 0.5, y0 + 0.5, bw - 1, bh - 1);
  set_color(kWhite);
  cairo_fill_preserve(cr_);
  set_color(Color{200, 200, 200});
  cairo_set_line_width(cr_, 1);
  cairo_stroke(cr_);
  for (std::size_t k = 0; k < entries.size(); ++k) {
    const auto& e = entries[k];
    const double cy = y0 + entry_xy[k][1] + row * 0.5 - 2;
    const double hx0 = x0 + entry_xy[k][0], hx1 = hx0 + kLegendHandle;
    if (e.patch) {
      const std::vector<P2> box{{hx0 + 4, cy - 6}, {hx1 - 4, cy - 6}, {hx1 - 4, cy + 6}, {hx0 + 4, cy + 6}};
      if (e.fill) fill_polygon(box, *e.fill);
      if (e.edge) stroke_polyline(box, 1, *e.edge, LineStyle::solid, true);
    } else {
      stroke_polyline({{hx0, cy}, {hx1, cy}}, e.width, e.color, e.style);
      marker({(hx0 + hx1) / 2, cy}, e.marker, e.marker_size, e.color);
    }
    text_.draw(hx1 + kLegendGap, cy, e.label, kLegendPx, kBlack, 0, 0, VAlign::center);
  }
}

}  // namespace pvdf::plot::detail
