// Internal pieces of pvdf::plot shared by its source files: what a panel holds, axis scales and
// ticks, and the text engine (math markup → Cairo glyph runs). Not installed, not public API.
#pragma once

#include "pvdf/core/constants.hpp"
#include "pvdf/plot/plot.hpp"

#include <cairo.h>

#include <array>
#include <cmath>
#include <limits>
#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace pvdf::plot::detail {

using P2 = std::array<double, 2>;
constexpr double kPi = pvdf::pi;
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
inline bool finite(double v) { return std::isfinite(v); }

// Font sizes in pixels of the PNG.
constexpr double kTickPx = 12, kLabelPx = 13, kTitlePx = 15, kSupTitlePx = 17, kLegendPx = 12, kContourPx = 11;
constexpr double kTickLen = 5;  // outward tick marks, px

// ---------------------------------------------------------------------------------------------
// What a panel holds.

enum class Kind { line, scatter, error_bars, field, contour, polygon, text, hline, vline };

struct Item {
  Kind kind = Kind::line;
  std::vector<double> x, y, err;
  std::string label;
  Color color;
  LineStyle style = LineStyle::solid;
  Marker marker = Marker::none;
  double width = 2, size = 6;
  // field / contour
  std::shared_ptr<const Grid> grid;
  bool diverging = false;
  std::optional<double> vmin, vmax;
  std::vector<double> levels;
  std::vector<std::vector<std::vector<P2>>> contours;  // per level
  std::string format;
  double scale = 1;
  // polygon
  std::vector<P2> vertices;
  std::optional<Color> fill, edge;
  // text
  double font_px = 12;
};

}  // namespace pvdf::plot::detail

namespace pvdf::plot {

struct Axes::Impl {
  std::vector<detail::Item> items;
  std::string title, xlabel, ylabel;
  std::optional<std::array<double, 2>> xlim, ylim;
  bool log_x = false, log_y = false, equal = false, grid = false, colorbar = true;
  bool integer_x = false;
  bool log_color = false;  // field coloured by log10, colour bar a log axis in the field's units
  std::vector<detail::P2> domain;  // fields drawn only inside this outline, at least domain_inset from it
  double domain_inset = 0;
  std::string legend_where = "best";
  std::size_t color_index = 0;
  std::optional<Color> last_color;

  Color next_color(std::optional<Color> c) {
    const Color out = c ? *c : cycle_color(color_index++);
    last_color = out;
    return out;
  }
  bool has_field() const {
    for (const auto& it : items)
      if (it.kind == detail::Kind::field) return true;
    return false;
  }
};

}  // namespace pvdf::plot

namespace pvdf::plot::detail {

/// Throws InputError unless the grid holds nx * ny values.
void check_grid(const Grid& g, const char* what);
/// True if the printf format takes exactly one floating-point number.
bool one_double_format(const std::string& f);

// ---------------------------------------------------------------------------------------------
// Axis scales and ticks (ticks.cpp). Tick labels are markup strings ("10$^{−3}$").

struct Scale {
  double lo = 0, hi = 1;
  bool log = false;
  bool integer = false;  // ticks on whole numbers only
  double p0 = 0, p1 = 1;  // pixel positions of lo and hi
  bool valid(double v) const { return finite(v) && (!log || v > 0); }
  double t(double v) const {
    if (log) return (std::log10(v) - std::log10(lo)) / (std::log10(hi) - std::log10(lo));
    return (v - lo) / (hi - lo);
  }
  double to_px(double v) const { return valid(v) ? p0 + t(v) * (p1 - p0) : kNaN; }
  double from_px(double p) const {
    const double s = (p - p0) / (p1 - p0);
    if (log) return std::pow(10.0, std::log10(lo) + s * (std::log10(hi) - std::log10(lo)));
    return lo + s * (hi - lo);
  }
};

struct Tick {
  double value = 0;
  std::string label;  // markup; empty for minor ticks
  bool major = true;
};

/// "-" → U+2212 MINUS SIGN at the front of a number.
std::string with_minus_sign(std::string s);
/// 1-2-5 ticks within [lo, hi], about `target` of them, labelled with just enough decimals.
/// Very large or small values are labelled by mantissas and one common `multiplier` ("×10^k",
/// empty otherwise); without a `multiplier` to fill, each label carries its own power of ten.
std::vector<Tick> linear_ticks(double lo, double hi, int target, std::string* multiplier = nullptr);
/// Decade ticks 10^k with minor ticks at 2..9 × 10^k; spans shorter than a decade fall back to 1-2-5.
std::vector<Tick> log_ticks(double lo, double hi, int target);
/// The whole numbers among linear_ticks(lo, hi, target), labelled without decimals.
std::vector<Tick> integer_ticks(double lo, double hi, int target);

// ---------------------------------------------------------------------------------------------
// Text (text.cpp): markup → runs of one size and baseline offset, measured and drawn by Cairo
// with the "DejaVu Sans" face that fontconfig finds (no font paths in the code).

enum class VAlign { baseline, top, center, bottom };

struct TextRun {
  std::string utf8;
  double size_px = 12;
  double dx = 0, dy = 0;  // offset of the run's origin from the text origin (y down)
};

struct TextLayout {
  std::vector<TextRun> runs;
  double width = 0;
  std::string plain;  // the characters shown, markup resolved
};

/// Turns markup into runs: between dollars `_x`, `_{..}`, `^x`, `^{..}` (nested), `\name` for
/// Greek letters and a few symbols; elsewhere characters as written. An unpaired `$` is literal.
std::vector<TextRun> parse_markup(const std::string& markup, double size_px);

/// Measures and draws text on a Cairo context; every drawn text is recorded (for SVG text layers
/// and Figure::texts()).
class TextEngine {
 public:
  explicit TextEngine(cairo_t* cr) : cr_(cr) {}
  TextLayout layout(const std::string& markup, double size_px, bool bold = false);
  double width(const std::string& markup, double size_px, bool bold = false) {
    return layout(markup, size_px, bold).width;
  }
  /// Draws at (x, y): `halign` 0 left … 1 right, `angle_deg` counter-clockwise.
  void draw(double x, double y, const std::string& markup, double size_px, Color c, double angle_deg = 0,
            double halign = 0, VAlign valign = VAlign::baseline, bool bold = false);

  struct Drawn {
    std::string plain;
    double x, y, size_px, angle_deg;  // baseline start after alignment
  };
  std::vector<Drawn> drawn;

 private:
  cairo_t* cr_;
};

/// A Cairo context on a 1 × 1 image, with the font options every figure uses (for measuring).
struct MeasureContext {
  MeasureContext();
  ~MeasureContext();
  MeasureContext(const MeasureContext&) = delete;
  MeasureContext& operator=(const MeasureContext&) = delete;
  cairo_surface_t* surface = nullptr;
  cairo_t* cr = nullptr;
};

/// Font options shared by all surfaces: no hinted metrics, so that a figure has the same layout
/// in PNG, SVG and PDF.
void set_font_options(cairo_t* cr);

}  // namespace pvdf::plot::detail
