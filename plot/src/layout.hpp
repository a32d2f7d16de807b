// Internal: where a panel's plot rectangle, ticks and colour bar go (layout.cpp).
#pragma once

#include "detail.hpp"

namespace pvdf::plot::detail {

struct ColorBar {
  bool on = false;
  double vmin = 0, vmax = 1;
  bool diverging = false;
  bool log = false;  // colours by log10 of the value; ticks in the value's units
  bool extend_lo = false, extend_hi = false;  // data beyond the colour range on that side
  std::string label;
  Scale scale;
  std::vector<Tick> ticks;
  std::string mult;  // common "×10^k" of the tick labels, if any
  double L = 0, T = 0, R = 0, B = 0;
  const Axes::Impl* panel = nullptr;  // whose contour levels are marked on the bar
};

constexpr double kBarGap = 16, kBarWidth = 18;
// Legend box: padding, line handle, gap to the text, space between entries side by side, and
// the gap between the panel (or its colour bar) and a legend placed outside it.
constexpr double kLegendPad = 7, kLegendHandle = 28, kLegendGap = 7, kLegendSpacing = 16, kLegendOutsideGap = 12;

/// True for items that get a legend entry (a label, and a kind that has a handle to draw).
bool has_legend_entry(const Item& it);

/// Everything a panel needs to be drawn, computed from its cell and its items.
struct PanelLayout {
  double L = 0, T = 0, R = 0, B = 0;  // plot rectangle [L, R) × [T, B) in PNG pixels (integers)
  Scale xs, ys;
  std::vector<Tick> xt, yt;
  std::string xmult, ymult;  // common "×10^k" of the tick labels, if any
  ColorBar cbar;
  double ytick_w = 0;
  std::string legend;  // placement, "best" with a field resolved to "outside below"
  // Outside placements: the box's top left (PNG pixels), size and each entry's offset in it.
  double legend_x0 = 0, legend_y0 = 0, legend_w = 0, legend_h = 0;
  std::vector<std::array<double, 2>> legend_entry_xy;
};

/// The colour bar of the last field of `a` (range, extends, label); off if it has none.
ColorBar panel_colorbar(const Axes::Impl& a);
/// Colour range of a field item: its finite values (symmetric about 0 when diverging; positive
/// ones only when `log`), or the caller's vmin/vmax; never zero-size.
std::array<double, 2> field_range(const Item& it, bool log = false);
/// Colour-bar ticks for a bar of `height_px`, and the width its tick labels and label need to
/// the right of the bar.
double colorbar_width(TextEngine& text, ColorBar& cb, double height_px);
/// Places the plot rectangle in the cell [cx0, cx1] × [cy0, cy1] so that ticks, labels, title
/// and (if `own_colorbar`) the colour bar fit.
PanelLayout layout_panel(TextEngine& text, const Axes::Impl& a, double cx0, double cy0, double cx1, double cy1,
                         bool own_colorbar);

}  // namespace pvdf::plot::detail
