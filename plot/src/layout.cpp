// Layout of a panel: data ranges (padded, equal aspect), ticks that fit without colliding, and
// room for tick labels, axis labels, title and colour bar.
#include "layout.hpp"

#include <algorithm>
#include <cstdio>

namespace pvdf::plot::detail {
namespace {

void collect_limits(const Axes::Impl& a, bool x_axis, bool log, double& lo, double& hi, bool& tight) {
  lo = std::numeric_limits<double>::infinity();
  hi = -lo;
  auto take = [&](double v) {
    if (!finite(v) || (log && !(v > 0))) return;
    lo = std::min(lo, v);
    hi = std::max(hi, v);
  };
  for (const auto& it : a.items) {
    switch (it.kind) {
      case Kind::line:
      case Kind::scatter:
        // Only points that can be drawn (both coordinates usable) count.
        for (std::size_t i = 0; i < it.x.size(); ++i) {
          const double x = it.x[i], y = it.y[i];
          if (!finite(x) || !finite(y) || (a.log_x && !(x > 0)) || (a.log_y && !(y > 0))) continue;
          take(x_axis ? x : y);
        }
        break;
      case Kind::error_bars:
        for (std::size_t i = 0; i < it.x.size(); ++i) {
          if (!finite(it.x[i]) || !finite(it.y[i])) continue;
          if (x_axis) take(it.x[i]);
          else if (finite(it.err[i])) take(it.y[i] - std::abs(it.err[i])), take(it.y[i] + std::abs(it.err[i]));
          else take(it.y[i]);
        }
        break;
      case Kind::field:
      case Kind::contour:
        if (it.grid->nx > 0 && it.grid->ny > 0) {
          take(x_axis ? it.grid->x0 : it.grid->y0);
          take(x_axis ? it.grid->x1 : it.grid->y1);
          tight = true;
        }
        break;
      case Kind::polygon:
        for (const auto& p : it.vertices) take(p[x_axis ? 0 : 1]);
        break;
      case Kind::hline:
        if (!x_axis) take(it.y[0]);
        break;
      case Kind::vline:
        if (x_axis) take(it.x[0]);
        break;
      case Kind::text: break;
    }
  }
}

/// Data range of one axis: the user's limits, else the data padded by 5 % (none for fields),
/// never empty or zero-size.
void resolve_range(const Axes::Impl& a, bool x_axis, Scale& s) {
  const bool log = x_axis ? a.log_x : a.log_y;
  s.log = log;
  s.integer = x_axis && a.integer_x && !log;
  const auto& user = x_axis ? a.xlim : a.ylim;
  double lo = 0, hi = 0;
  bool tight = false;
  if (user && (!log || ((*user)[0] > 0 && (*user)[1] > 0))) {
    lo = std::min((*user)[0], (*user)[1]);
    hi = std::max((*user)[0], (*user)[1]);
    tight = true;
  } else {
    collect_limits(a, x_axis, log, lo, hi, tight);
    if (!(lo <= hi)) {
      lo = log ? 1 : 0;
      hi = log ? 10 : 1;
      tight = true;
    }
  }
  if (log) {
    double l0 = std::log10(lo), l1 = std::log10(hi);
    if (!(l1 - l0 > 1e-9)) l0 -= 0.5, l1 += 0.5;
    if (!tight) {
      const double pad = 0.05 * (l1 - l0);
      l0 -= pad, l1 += pad;
    }
    lo = std::pow(10.0, std::clamp(l0, -300.0, 300.0));
    hi = std::pow(10.0, std::clamp(l1, -300.0, 300.0));
    if (!(hi > lo)) hi = lo * 10;
  } else {
    lo = std::clamp(lo, -1e300, 1e300);
    hi = std::clamp(hi, -1e300, 1e300);
    const double mag = std::max(std::abs(lo), std::abs(hi));
    if (!(hi - lo > 1e-12 * mag) || !(hi - lo > 1e-300)) {
      const double d = mag > 0 ? 0.1 * mag : 1.0;
      lo -= d, hi += d;
    }
    if (!tight) {
      const double pad = 0.05 * (hi / 2 - lo / 2) * 2;
      lo -= pad, hi += pad;
    }
  }
  s.lo = lo;
  s.hi = hi;
}

std::vector<Tick> make_ticks(const Scale& s, int target, std::string* multiplier) {
  if (s.log) {
    multiplier->clear();
    return log_ticks(s.lo, s.hi, target);
  }
  if (s.integer) {
    multiplier->clear();
    return integer_ticks(s.lo, s.hi, target);
  }
  return linear_ticks(s.lo, s.hi, target, multiplier);
}

/// Picks the densest tick set whose labels do not collide along an axis of `length_px`, with at
/// least two labelled ticks where the range allows.
std::vector<Tick> fit_ticks(TextEngine& text, const Scale& s, double length_px, bool horizontal,
                            std::string* multiplier) {
  auto n_labelled = [](const std::vector<Tick>& ticks) {
    int n = 0;
    for (const auto& t : ticks) n += t.major && !t.label.empty();
    return n;
  };
  auto collide = [&](const std::vector<Tick>& ticks) {
    double need = 0;
    for (const auto& t : ticks) {
      if (!t.major || t.label.empty()) continue;
      need += horizontal ? text.width(t.label, kTickPx) + 14 : kTickPx * 1.9;
    }
    return need > std::abs(length_px);
  };
  int target = std::clamp(static_cast<int>(std::abs(length_px) / (horizontal ? 75.0 : 45.0)), 3, 12);
  auto ticks = make_ticks(s, target, multiplier);
  while (n_labelled(ticks) < 2 && target < 12) ticks = make_ticks(s, ++target, multiplier);
  while (collide(ticks) && target > 1) {
    std::string m;
    auto fewer = make_ticks(s, --target, &m);
    if (n_labelled(fewer) < 2) break;
    ticks = std::move(fewer);
    *multiplier = m;
  }
  return ticks;
}

double max_tick_width(TextEngine& text, const std::vector<Tick>& ticks) {
  double w = 0;
  for (const auto& t : ticks)
    if (t.major) w = std::max(w, text.width(t.label, kTickPx));
  return w;
}

}  // namespace

std::array<double, 2> field_range(const Item& it, bool log) {
  double lo = std::numeric_limits<double>::infinity(), hi = -lo;
  for (double v : it.grid->values) {
    if (!finite(v) || (log && !(v > 0))) continue;
    lo = std::min(lo, v), hi = std::max(hi, v);
  }
  if (!(lo <= hi)) lo = log ? 0.1 : 0, hi = log ? 10 : 1;
  if (it.diverging && !log && !it.vmin && !it.vmax) {
    const double m = std::max(std::abs(lo), std::abs(hi));
    lo = -m, hi = m;
  }
  if (it.vmin && (!log || *it.vmin > 0)) lo = *it.vmin;
  if (it.vmax && (!log || *it.vmax > 0)) hi = *it.vmax;
  if (lo > hi) std::swap(lo, hi);
  if (log) {
    if (!(hi > lo * (1 + 1e-9))) lo /= 2, hi *= 2;
    return {lo, hi};
  }
  const double mag = std::max(std::abs(lo), std::abs(hi));
  if (!(hi - lo > 1e-12 * mag) || !(hi - lo > 1e-300)) {
    const double d = mag > 0 ? 0.1 * mag : 1.0;
    lo -= d, hi += d;
  }
  return {lo, hi};
}

ColorBar panel_colorbar(const Axes::Impl& a) {
  ColorBar cb;
  for (const auto& it : a.items) {
    if (it.kind != Kind::field) continue;
    const auto range = field_range(it, a.log_color);
    cb.on = true;
    cb.log = a.log_color;
    cb.vmin = range[0];
    cb.vmax = range[1];
    cb.diverging = it.diverging;
    cb.label = it.label;
    cb.panel = &a;
    double lo = std::numeric_limits<double>::infinity(), hi = -lo;
    for (double v : it.grid->values) {
      if (std::isnan(v)) continue;
      if (cb.log && !(v > 0)) v = -std::numeric_limits<double>::infinity();  // drawn as below the scale
      lo = std::min(lo, v), hi = std::max(hi, v);
    }
    const double tol = 1e-9 * (cb.vmax - cb.vmin);
    cb.extend_lo = lo < cb.vmin - tol;
    cb.extend_hi = hi > cb.vmax + tol;
  }
  cb.scale.lo = cb.vmin;
  cb.scale.hi = cb.vmax;
  cb.scale.log = cb.log;
  return cb;
}

double colorbar_width(TextEngine& text, ColorBar& cb, double height_px) {
  const int target = std::clamp(static_cast<int>(height_px / 50), 2, 10);
  if (cb.log) {
    // In the field's own units (0.01, 0.1, 1 mm), never as exponents of 10 alone.
    cb.mult.clear();
    cb.ticks = log_ticks(cb.vmin, cb.vmax, target);
    for (auto& t : cb.ticks) {
      if (t.label.empty() || t.label.find("10$^") == std::string::npos || !(t.value >= 1e-4 && t.value < 1e5)) continue;
      char buffer[32];
      std::snprintf(buffer, sizeof buffer, "%g", t.value);
      t.label = with_minus_sign(buffer);
    }
  } else {
    cb.ticks = linear_ticks(cb.vmin, cb.vmax, target, &cb.mult);
  }
  return kBarGap + kBarWidth + kTickLen + 4 + max_tick_width(text, cb.ticks) + (cb.label.empty() ? 0 : 10 + kLabelPx);
}

bool has_legend_entry(const Item& it) {
  if (it.label.empty()) return false;
  switch (it.kind) {
    case Kind::line:
    case Kind::scatter:
    case Kind::contour:
    case Kind::hline:
    case Kind::vline:
    case Kind::polygon: return true;
    default: return false;
  }
}

namespace {

/// Where the legend's entries go for a placement (inside the box, from its top left) and the
/// box's size; "outside below" packs entries side by side into rows no wider than `max_width`.
void legend_box(TextEngine& text, const Axes::Impl& a, const std::string& where, double max_width, PanelLayout& p) {
  p.legend_entry_xy.clear();
  p.legend_w = p.legend_h = 0;
  std::vector<double> widths;
  for (const auto& it : a.items)
    if (has_legend_entry(it)) widths.push_back(kLegendHandle + kLegendGap + text.width(it.label, kLegendPx));
  if (widths.empty()) return;
  const double row = kLegendPx * 1.5;
  if (where == "outside below") {
    double x = kLegendPad, y = kLegendPad, w = 0;
    for (double ew : widths) {
      if (x > kLegendPad && x + ew + kLegendPad > max_width) x = kLegendPad, y += row;
      p.legend_entry_xy.push_back({x, y});
      x += ew + kLegendSpacing;
      w = std::max(w, x - kLegendSpacing + kLegendPad);
    }
    p.legend_w = w;
    p.legend_h = y + row + kLegendPad - 4;
    return;
  }
  double tw = 0;
  for (std::size_t k = 0; k < widths.size(); ++k) {
    tw = std::max(tw, widths[k]);
    p.legend_entry_xy.push_back({kLegendPad, kLegendPad + row * static_cast<double>(k)});
  }
  p.legend_w = kLegendPad + tw + kLegendPad;
  p.legend_h = kLegendPad + row * static_cast<double>(widths.size()) + kLegendPad - 4;
}

}  // namespace

PanelLayout layout_panel(TextEngine& text, const Axes::Impl& a, double cx0, double cy0, double cx1, double cy1,
                         bool own_colorbar) {
  PanelLayout p;
  resolve_range(a, true, p.xs);
  resolve_range(a, false, p.ys);
  if (own_colorbar && a.colorbar) p.cbar = panel_colorbar(a);
  // A legend inside a filled field always hides data: "best" puts it under the panel.
  p.legend = a.legend_where == "best" && a.has_field() ? "outside below" : a.legend_where;
  const bool legend_right = p.legend == "outside right", legend_below = p.legend == "outside below";
  const double pad = 10;
  const double top = pad + (a.title.empty() ? 4 : kTitlePx + 12);
  const double bottom = kTickLen + 4 + kTickPx + (a.xlabel.empty() ? 0 : 10 + kLabelPx) + pad;
  const bool equal = a.equal && !p.xs.log && !p.ys.log;
  double L = cx0 + 70, R = cx1 - 20, T = cy0 + top, B = cy1 - bottom;
  // Equal aspect: the plot rectangle shrinks along the axis with fewer data units per pixel so
  // that the data fill it (no empty bands inside the axes); only a very elongated rectangle
  // (under a quarter of its room) widens the data range instead.
  auto equal_lengths = [&](double w, double h, double& we, double& he) {
    we = w, he = h;
    if (!equal) return;
    const double ux = (p.xs.hi - p.xs.lo) / w, uy = (p.ys.hi - p.ys.lo) / h;
    if (ux > uy) he = std::max(0.25 * h, (p.ys.hi - p.ys.lo) / ux);
    else we = std::max(0.25 * w, (p.xs.hi - p.xs.lo) / uy);
  };
  for (int pass = 0; pass < 3; ++pass) {
    const double w = std::max(R - L, 10.0), h = std::max(B - T, 10.0);
    double we = w, he = h;
    equal_lengths(w, h, we, he);
    p.xt = fit_ticks(text, p.xs, we, true, &p.xmult);
    p.yt = fit_ticks(text, p.ys, he, false, &p.ymult);
    p.ytick_w = max_tick_width(text, p.yt);
    double right = pad;
    for (const auto& t : p.xt) {
      // The last x tick label may stick out to the right of the frame.
      if (!t.major) continue;
      const double x = L + p.xs.t(t.value) * w;
      right = std::max(right, x + text.width(t.label, kTickPx) / 2 - R + pad);
    }
    if (p.cbar.on) right = colorbar_width(text, p.cbar, he) + pad;
    if (legend_right) {
      legend_box(text, a, p.legend, 0, p);
      if (p.legend_w > 0) right += p.legend_w + kLegendOutsideGap;
    }
    double below = 0;
    if (legend_below) {
      legend_box(text, a, p.legend, cx1 - cx0 - 2 * pad, p);
      if (p.legend_h > 0) below = p.legend_h + kLegendOutsideGap;
    }
    const double left = pad + (a.ylabel.empty() ? 0 : kLabelPx + 10) + p.ytick_w + 4 + kTickLen;
    // Room for a "×10^k" above the y axis or colour bar, and below the x tick labels.
    const bool mult_above = !p.ymult.empty() || (p.cbar.on && !p.cbar.mult.empty());
    const double top_now = std::max(top, mult_above ? pad + kTickPx + 8 : 0.0);
    const double bottom_now = (a.xlabel.empty() && !p.xmult.empty() ? bottom + 10 + kTickPx : bottom) + below;
    L = cx0 + left;
    R = cx1 - right;
    T = cy0 + top_now;
    B = cy1 - bottom_now;
    if (R - L < 20) R = L + 20;
    if (B - T < 20) B = T + 20;
  }
  if (equal) {
    double we = R - L, he = B - T;
    equal_lengths(R - L, B - T, we, he);
    const double cx = (L + R) / 2, cy = (T + B) / 2;
    L = cx - we / 2, R = cx + we / 2, T = cy - he / 2, B = cy + he / 2;
  }
  p.L = std::round(L), p.R = std::round(R), p.T = std::round(T), p.B = std::round(B);
  if (equal) {
    // Exactly equal scales on the final (whole-pixel) rectangle: the rounding (or a rectangle
    // too elongated to shrink) is absorbed by widening one data range.
    const double ux = (p.xs.hi - p.xs.lo) / (p.R - p.L), uy = (p.ys.hi - p.ys.lo) / (p.B - p.T);
    if (ux > uy) {
      const double c = (p.ys.lo + p.ys.hi) / 2, half = ux * (p.B - p.T) / 2;
      p.ys.lo = c - half, p.ys.hi = c + half;
    } else {
      const double c = (p.xs.lo + p.xs.hi) / 2, half = uy * (p.R - p.L) / 2;
      p.xs.lo = c - half, p.xs.hi = c + half;
    }
    p.xt = fit_ticks(text, p.xs, p.R - p.L, true, &p.xmult);
    p.yt = fit_ticks(text, p.ys, p.B - p.T, false, &p.ymult);
    p.ytick_w = max_tick_width(text, p.yt);
  }
  p.xs.p0 = p.L, p.xs.p1 = p.R;
  p.ys.p0 = p.B, p.ys.p1 = p.T;
  if (p.cbar.on) {
    p.cbar.L = p.R + kBarGap;
    p.cbar.R = p.cbar.L + kBarWidth;
    p.cbar.T = p.T;
    p.cbar.B = p.B;
    colorbar_width(text, p.cbar, p.B - p.T);
  }
  if (legend_right && p.legend_w > 0) {
    const double after = p.cbar.on ? p.cbar.L + colorbar_width(text, p.cbar, p.B - p.T) - kBarGap : p.R;
    p.legend_x0 = std::round(after + kLegendOutsideGap);
    p.legend_y0 = p.T;
  } else if (legend_below && p.legend_h > 0) {
    legend_box(text, a, p.legend, cx1 - cx0 - 2 * pad, p);
    p.legend_x0 = std::round(std::clamp((p.L + p.R - p.legend_w) / 2, cx0 + pad, cx1 - pad - p.legend_w));
    p.legend_y0 = std::round(p.B + kTickLen + 5 + kTickPx + (a.xlabel.empty() ? 0 : 9 + kLabelPx) + kLegendOutsideGap);
  }
  return p;
}

}  // namespace pvdf::plot::detail
