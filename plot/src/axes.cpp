// The Axes API: each call records an item (line, field, contour, ...) that Figure draws later.
#include "detail.hpp"

#include "pvdf/core/error.hpp"

#include <algorithm>

namespace pvdf::plot {

using detail::finite;
using detail::Item;
using detail::Kind;

Axes& Axes::line(const std::vector<double>& x, const std::vector<double>& y, const std::string& label,
                 std::optional<Color> color, LineStyle style, Marker marker, double width_px) {
  Item it;
  it.kind = Kind::line;
  const std::size_t n = std::min(x.size(), y.size());
  it.x.assign(x.begin(), x.begin() + static_cast<std::ptrdiff_t>(n));
  it.y.assign(y.begin(), y.begin() + static_cast<std::ptrdiff_t>(n));
  it.label = label;
  it.color = impl_->next_color(color);
  it.style = style;
  it.marker = marker;
  it.width = finite(width_px) ? std::clamp(width_px, 0.5, 50.0) : 2.0;
  it.size = std::max(6.0, 2.5 * it.width + 2);
  impl_->items.push_back(std::move(it));
  return *this;
}

Axes& Axes::scatter(const std::vector<double>& x, const std::vector<double>& y, const std::string& label,
                    std::optional<Color> color, Marker marker, double size_px) {
  Item it;
  it.kind = Kind::scatter;
  const std::size_t n = std::min(x.size(), y.size());
  it.x.assign(x.begin(), x.begin() + static_cast<std::ptrdiff_t>(n));
  it.y.assign(y.begin(), y.begin() + static_cast<std::ptrdiff_t>(n));
  it.label = label;
  it.color = impl_->next_color(color);
  it.marker = marker == Marker::none ? Marker::circle : marker;
  it.style = LineStyle::none;
  it.size = finite(size_px) ? std::clamp(size_px, 1.0, 100.0) : 6.0;
  impl_->items.push_back(std::move(it));
  return *this;
}

Axes& Axes::error_bars(const std::vector<double>& x, const std::vector<double>& y, const std::vector<double>& err,
                       std::optional<Color> color) {
  Item it;
  it.kind = Kind::error_bars;
  const std::size_t n = std::min({x.size(), y.size(), err.size()});
  it.x.assign(x.begin(), x.begin() + static_cast<std::ptrdiff_t>(n));
  it.y.assign(y.begin(), y.begin() + static_cast<std::ptrdiff_t>(n));
  it.err.assign(err.begin(), err.begin() + static_cast<std::ptrdiff_t>(n));
  it.color = color ? *color : impl_->last_color ? *impl_->last_color : impl_->next_color(std::nullopt);
  impl_->items.push_back(std::move(it));
  return *this;
}

Axes& Axes::field(const Grid& grid, const std::string& colorbar_label, bool diverging, std::optional<double> vmin,
                  std::optional<double> vmax) {
  detail::check_grid(grid, "field");
  Item it;
  it.kind = Kind::field;
  it.grid = std::make_shared<const Grid>(grid);
  it.label = colorbar_label;
  it.diverging = diverging;
  if (vmin && finite(*vmin)) it.vmin = vmin;
  if (vmax && finite(*vmax)) it.vmax = vmax;
  impl_->items.push_back(std::move(it));
  return *this;
}

Axes& Axes::contour(const Grid& grid, const std::vector<double>& levels, std::optional<Color> color, double width_px,
                    const std::string& label_format, double label_scale, const std::string& legend_label) {
  detail::check_grid(grid, "contour");
  if (!label_format.empty() && !detail::one_double_format(label_format)) {
    throw InputError("plot contour: label format \"" + label_format +
                     "\" must hold exactly one %f, %e or %g conversion (write %% for a percent sign)");
  }
  Item it;
  it.kind = Kind::contour;
  it.grid = std::make_shared<const Grid>(grid);
  // Traced on the smooth interpolant, refined to at least ~400 cells along the longer side (at
  // most 8 times, and about 4 million nodes): marching squares then follows the curve, not the
  // chords of the coarse cells.
  const std::size_t cells = std::max<std::size_t>(1, std::max(grid.nx, grid.ny) - 1);
  int factor = std::clamp(static_cast<int>((400 + cells - 1) / cells), 1, 8);
  while (factor > 1 && static_cast<double>(grid.nx) * grid.ny * factor * factor > 4e6) --factor;
  const Grid fine = grid.nx >= 2 && grid.ny >= 2 ? refine_grid(grid, factor) : grid;
  for (double level : levels) {
    if (!finite(level)) continue;
    it.levels.push_back(level);
    it.contours.push_back(contour_lines(fine, level));
  }
  it.color = color ? *color : impl_->has_field() ? Color{20, 20, 20} : impl_->next_color(std::nullopt);
  it.width = finite(width_px) ? std::clamp(width_px, 0.5, 50.0) : 1.5;
  it.format = label_format;
  it.scale = finite(label_scale) ? label_scale : 1.0;
  it.label = legend_label;
  impl_->items.push_back(std::move(it));
  return *this;
}

Axes& Axes::polygon(const std::vector<std::array<double, 2>>& vertices, std::optional<Color> fill,
                    std::optional<Color> edge, double edge_width_px, const std::string& label) {
  Item it;
  it.kind = Kind::polygon;
  it.vertices = vertices;
  it.fill = fill;
  it.edge = edge;
  it.width = finite(edge_width_px) ? std::clamp(edge_width_px, 0.0, 50.0) : 1.0;
  it.label = label;
  impl_->items.push_back(std::move(it));
  return *this;
}

Axes& Axes::text(double x, double y, const std::string& text, Color color, double size_pt) {
  Item it;
  it.kind = Kind::text;
  it.x = {x};
  it.y = {y};
  it.label = text;
  it.color = color;
  it.font_px = finite(size_pt) ? std::clamp(size_pt * 1.25, 4.0, 200.0) : 12.5;  // 90 dpi
  impl_->items.push_back(std::move(it));
  return *this;
}

Axes& Axes::hline(double y, Color color, LineStyle style, const std::string& label) {
  Item it;
  it.kind = Kind::hline;
  it.y = {y};
  it.color = color;
  it.style = style;
  it.width = 1.3;
  it.label = label;
  impl_->items.push_back(std::move(it));
  return *this;
}

Axes& Axes::vline(double x, Color color, LineStyle style, const std::string& label) {
  Item it;
  it.kind = Kind::vline;
  it.x = {x};
  it.color = color;
  it.style = style;
  it.width = 1.3;
  it.label = label;
  impl_->items.push_back(std::move(it));
  return *this;
}

Axes& Axes::title(const std::string& t) { impl_->title = t; return *this; }
Axes& Axes::xlabel(const std::string& t) { impl_->xlabel = t; return *this; }
Axes& Axes::ylabel(const std::string& t) { impl_->ylabel = t; return *this; }
Axes& Axes::xlim(double lo, double hi) {
  if (finite(lo) && finite(hi)) impl_->xlim = std::array<double, 2>{lo, hi};
  return *this;
}
Axes& Axes::ylim(double lo, double hi) {
  if (finite(lo) && finite(hi)) impl_->ylim = std::array<double, 2>{lo, hi};
  return *this;
}
Axes& Axes::log_x(bool on) { impl_->log_x = on; return *this; }
Axes& Axes::log_y(bool on) { impl_->log_y = on; return *this; }
Axes& Axes::integer_x(bool on) { impl_->integer_x = on; return *this; }
Axes& Axes::equal_aspect(bool on) { impl_->equal = on; return *this; }
Axes& Axes::grid_lines(bool on) { impl_->grid = on; return *this; }
Axes& Axes::legend(const std::string& where) {
  static const char* const allowed[] = {"best",       "upper right",   "upper left",   "lower right",
                                        "lower left", "outside right", "outside below", "none"};
  for (const char* a : allowed) {
    if (where == a) {
      impl_->legend_where = where;
      return *this;
    }
  }
  throw InputError("plot legend: placement \"" + where +
                   "\" is not one of best, upper right, upper left, lower right, lower left, outside right, "
                   "outside below, none");
}
Axes& Axes::log_color(bool on) {
  impl_->log_color = on;
  return *this;
}
Axes& Axes::field_domain(const std::vector<std::array<double, 2>>& outline, double inset) {
  impl_->domain.clear();
  if (outline.size() >= 3) {
    for (const auto& v : outline) {
      if (!finite(v[0]) || !finite(v[1])) throw InputError("plot field_domain: the outline holds a non-finite vertex");
    }
    impl_->domain = outline;
  }
  impl_->domain_inset = finite(inset) ? inset : 0;
  return *this;
}
Axes& Axes::colorbar(bool on) {
  impl_->colorbar = on;
  return *this;
}

}  // namespace pvdf::plot
