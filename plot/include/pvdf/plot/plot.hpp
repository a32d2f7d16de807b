// Figures a person wants to look at — line plots, scatter, filled fields with contours, polygons
// (mesh previews) with labelled axes, ticks, legends and titles — drawn with Cairo and saved as
// PNG, SVG or PDF (chosen by the file extension).
#pragma once

#include <array>
#include <optional>
#include <string>
#include <vector>

namespace pvdf::plot {

/// RGB colour, components 0..255.
struct Color {
  unsigned char r = 0, g = 0, b = 0;
};

/// The default cycle of line colours (colour-blind-friendly); `index` wraps around.
Color cycle_color(std::size_t index);
/// Perceptually ordered colour map (viridis-like), t in [0, 1].
Color colormap(double t);
/// Diverging colour map (blue–white–red), t in [0, 1], 0.5 is white.
Color colormap_diverging(double t);

enum class LineStyle { solid, dashed, dotted, none };
enum class Marker { none, circle, square, triangle, cross, plus };

/// A regular grid of values over [x0, x1] × [y0, y1] (nx × ny nodes, row-major in y:
/// value(i, j) = values[j * nx + i]). NaN marks "no value" (drawn as background).
struct Grid {
  double x0 = 0, x1 = 1, y0 = 0, y1 = 1;
  std::size_t nx = 0, ny = 0;
  std::vector<double> values;
  double at(std::size_t i, std::size_t j) const { return values[j * nx + i]; }
};

/// Contour polylines of `grid` at `level` by marching squares on the grid cells (linear
/// interpolation along cell edges; cells with a NaN corner are skipped; saddles resolved by the
/// cell-centre average). Each polyline is a list of (x, y) points in data units; a closed loop
/// repeats its first point at the end. Throws InputError if values.size() != nx * ny.
std::vector<std::vector<std::array<double, 2>>> contour_lines(const Grid& grid, double level);

/// The grid sampled `factor` times finer ((nx − 1)·factor + 1 nodes along x, likewise y) on its
/// smooth interpolant: Keys' bicubic convolution (passes through the nodes, continuous gradient,
/// exact for quadratics; ghost nodes extrapolated quadratically at the edges), bilinear in cells
/// whose 4 × 4 stencil holds a NaN, NaN in cells with a NaN corner. Throws InputError if
/// values.size() != nx * ny or factor is not in 1..64.
Grid refine_grid(const Grid& grid, int factor);

/// One panel of a figure: data coordinates, axes, ticks, labels, legend.
/// Every label and text is UTF-8 ("µm", "β", "ν") and may hold math between dollars: "$E_x$",
/// "$\\nu_{xy}$", "m$^2$", "$d^{C_2}$", "$\\sigma$ (MPa)" give (nested) sub/superscripts and Greek
/// letters. Outside dollars every character is drawn as written (file names keep their "_").
class Axes {
 public:
  /// Line and/or markers through points (NaN breaks the line).
  Axes& line(const std::vector<double>& x, const std::vector<double>& y, const std::string& label = "",
             std::optional<Color> color = std::nullopt, LineStyle style = LineStyle::solid,
             Marker marker = Marker::none, double width_px = 2.0);
  /// Markers only.
  Axes& scatter(const std::vector<double>& x, const std::vector<double>& y, const std::string& label = "",
                std::optional<Color> color = std::nullopt, Marker marker = Marker::circle, double size_px = 6.0);
  /// Error bars (vertical, ± err).
  Axes& error_bars(const std::vector<double>& x, const std::vector<double>& y, const std::vector<double>& err,
                   std::optional<Color> color = std::nullopt);
  /// Filled field (colour map) with a colour bar labelled `colorbar_label`, coloured by its smooth
  /// interpolant (see refine_grid); next to NaN nodes the field ends halfway between valid and
  /// missing nodes along a smooth edge. Values outside [vmin, vmax] take the end colours, and the
  /// colour bar then ends in a triangle on that side (the usual mark of a clipped scale).
  Axes& field(const Grid& grid, const std::string& colorbar_label, bool diverging = false,
              std::optional<double> vmin = std::nullopt, std::optional<double> vmax = std::nullopt);
  /// Contour lines of a grid at `levels`, optionally labelled with their value (`label_format`
  /// is a printf format such as "%.0f pC", values multiplied by `label_scale` first). The lines
  /// are traced on the grid's smooth interpolant (refine_grid, to at least ~400 cells a side),
  /// the same interpolant field() colours with, so coarse grids give smooth curves.
  Axes& contour(const Grid& grid, const std::vector<double>& levels, std::optional<Color> color = std::nullopt,
                double width_px = 1.5, const std::string& label_format = "", double label_scale = 1.0,
                const std::string& legend_label = "");
  /// Closed polygon, filled and/or outlined.
  Axes& polygon(const std::vector<std::array<double, 2>>& vertices, std::optional<Color> fill,
                std::optional<Color> edge = Color{0, 0, 0}, double edge_width_px = 1.0, const std::string& label = "");
  /// Text at a data point.
  Axes& text(double x, double y, const std::string& text, Color color = Color{0, 0, 0}, double size_pt = 10);
  /// Horizontal / vertical reference lines.
  Axes& hline(double y, Color color = Color{120, 120, 120}, LineStyle style = LineStyle::dashed, const std::string& label = "");
  Axes& vline(double x, Color color = Color{120, 120, 120}, LineStyle style = LineStyle::dashed, const std::string& label = "");

  Axes& title(const std::string& t);
  Axes& xlabel(const std::string& t);
  Axes& ylabel(const std::string& t);
  Axes& xlim(double lo, double hi);
  Axes& ylim(double lo, double hi);
  Axes& log_x(bool on = true);
  Axes& log_y(bool on = true);
  /// Ticks on whole numbers only (counts, row numbers): 1, 2, 3, not 2.5.
  Axes& integer_x(bool on = true);
  /// Same scale on both axes (maps, meshes).
  Axes& equal_aspect(bool on = true);
  Axes& grid_lines(bool on = true);
  /// Legend placement: "best", "upper right", "upper left", "lower right", "lower left", "none",
  /// or off the data: "outside right" (beside the plot and its colour bar) or "outside below"
  /// (under the x label, entries side by side where they fit). "best" picks the corner covering
  /// the fewest data points, and "outside below" for a panel with a filled field, which a legend
  /// inside would always hide.
  Axes& legend(const std::string& where = "best");
  /// Colour this panel's fields only inside the closed polygon `outline` (data units, either
  /// orientation) and at least `inset` from it, with an anti-aliased edge. The area a charge map
  /// covers — the film less its rim margin — then ends on that smooth curve, not on the grid's
  /// steps: missing nodes next to finite ones first take the mean of their finite neighbours (one
  /// ring of extrapolation, so the interpolant reaches the curve), then the curve cuts it. Round
  /// outlines are given as polygons of enough vertices (≥ 128). An outline of < 3 points clears it.
  Axes& field_domain(const std::vector<std::array<double, 2>>& outline, double inset = 0);
  /// Show (default) or hide this panel's colour bar.
  Axes& colorbar(bool on = true);
  /// Colour the field by log10 of its values (which stay in physical units, e.g. mm): the colour
  /// bar is a log axis labelled in those units (0.01, 0.1, 1 mm), vmin/vmax are in those units,
  /// values <= 0 are drawn as below the scale and +inf as above it.
  Axes& log_color(bool on = true);

  struct Impl;
  Impl* impl() const { return impl_; }
  explicit Axes(Impl* impl) : impl_(impl) {}

 private:
  Impl* impl_;
};

/// A figure of rows × cols panels, saved as PNG, SVG or PDF (written atomically). Sizes are in
/// pixels of the PNG; SVG and PDF pages have the same layout at 0.75 pt per pixel (96 dpi).
class Figure {
 public:
  Figure(int width_px = 1000, int height_px = 700, int rows = 1, int cols = 1);
  ~Figure();
  Figure(const Figure&) = delete;
  Figure& operator=(const Figure&) = delete;

  /// Panel at (row, col), 0-based.
  Axes& axes(int row = 0, int col = 0);
  /// Title over all panels.
  Figure& suptitle(const std::string& t);
  /// One colour bar for the whole figure, at its right edge, instead of one per panel: for
  /// panels that share a colour scale. It shows the first panel's field that has one.
  Figure& shared_colorbar(bool on = true);
  /// Renders and writes the file; the format follows the extension: .png, .svg or .pdf (any
  /// case). Throws InputError for another extension or a path that cannot be written.
  void save(const std::string& path) const;
  /// Same as save() (the name predates SVG and PDF output; the extension still decides).
  void save_png(const std::string& path) const { save(path); }
  /// Every text drawn (titles, labels, tick labels, legend, annotations), with the math
  /// markup resolved to the characters shown ("$\\nu_{xy}$" → "νxy"), in drawing order.
  std::vector<std::string> texts() const;
  /// Where data point (x, y) of panel (row, col) lands in the saved PNG, in pixels (x right,
  /// y down, pixel (i, j) spans [i, i+1) × [j, j+1)), with the same layout as save_png.
  std::array<double, 2> data_to_pixel(int row, int col, double x, double y) const;

  struct Impl;

 private:
  Impl* impl_;
};

}  // namespace pvdf::plot
