// Layout of a panel: data ranges (padded, equal aspect), ticks that fit without colliding, and
// room for tick labels, axis labels, title and colour bar.
#include "layout.hpp"

#include <algorithm>

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

std::array<double, 2> field_range(const Item& it) {
  double lo = std::numeric_limits<double>::infinity(), hi = -lo;
  for (double v : it.grid->values) {
    if (!finite(v)) continue;
    lo = std::min(lo, v), hi = std::max(hi, v);
  }
  if (!(lo <= hi)) lo = 0, hi = 1;
  if (it.diverging && !it.vmin && !it.vmax) {
    const double m = std::max(std::abs(lo), std::abs(hi));
    lo = -m, hi = m;
  }
  if (it.vmin) lo = *it.vmin;
  if (it.vmax) hi = *it.vmax;
  if (lo > hi) std::swap(lo, hi);
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
    const auto range = field_range(it);
    cb.on = true;
    cb.vmin = range[0];
    cb.vmax = range[1];
    cb.diverging = it.diverging;
    cb.label = it.label;
    cb.panel = &a;
    double lo = std::numeric_limits<double>::infinity(), hi = -lo;
    for (double v : it.grid->values) {
      if (finite(v)) lo = std::min(lo, v), hi = std::max(hi, v);
    }
    const double tol = 1e-9 * (cb.vmax - cb.vmin);
    cb.extend_lo = lo < cb.vmin - tol;
    cb.extend_hi = hi > cb.vmax + tol;
  }
  cb.scale.lo = cb.vmin;
  cb.scale.hi = cb.vmax;
  return cb;
}

double colorbar_width(TextEngine& text, ColorBar& cb, double height_px) {
  cb.ticks = linear_ticks(cb.vmin, cb.vmax, std::clamp(static_cast<int>(height_px / 50), 2, 10), &cb.mult);
  return kBarGap + kBarWidth + kTickLen + 4 + max_tick_width(text, cb.ticks) + (cb.label.empty() ? 0 : 10 + kLabelPx);
}

PanelLayout layout_panel(TextEngine& text, const Axes::Impl& a, double cx0, double cy0, double cx1, double cy1,
                         bool own_colorbar) {
  PanelLayout p;
  resolve_range(a, true, p.xs);
  resolve_range(a, false, p.ys);
  if (own_colorbar && a.colorbar) p.cbar = panel_colorbar(a);
  const double pad = 10;
  const double top = pad + (a.title.empty() ? 4 : kTitlePx + 12);
  const double bottom = kTickLen + 4 + kTickPx + (a.xlabel.empty() ? 0 : 10 + kLabelPx) + pad;
  double L = cx0 + 70, R = cx1 - 20, T = cy0 + top, B = cy1 - bottom;
  for (int pass = 0; pass < 3; ++pass) {
    const double w = std::max(R - L, 10.0), h = std::max(B - T, 10.0);
    // Equal aspect: widen the range of the axis with fewer data units per pixel.
    if (a.equal && !p.xs.log && !p.ys.log) {
      Scale xs, ys;
      resolve_range(a, true, xs);
      resolve_range(a, false, ys);
      const double ux = (xs.hi - xs.lo) / w, uy = (ys.hi - ys.lo) / h;
      if (ux > uy) {
        const double c = (ys.lo + ys.hi) / 2, half = ux * h / 2;
        ys.lo = c - half, ys.hi = c + half;
      } else {
        const double c = (xs.lo + xs.hi) / 2, half = uy * w / 2;
        xs.lo = c - half, xs.hi = c + half;
      }
      p.xs.lo = xs.lo, p.xs.hi = xs.hi, p.ys.lo = ys.lo, p.ys.hi = ys.hi;
    }
    p.xt = fit_ticks(text, p.xs, w, true, &p.xmult);
    p.yt = fit_ticks(text, p.ys, h, false, &p.ymult);
    p.ytick_w = max_tick_width(text, p.yt);
    double right = pad;
    for (const auto& t : p.xt) {
      // The last x tick label may stick out to the right of the frame.
      if (!t.major) continue;
      const double x = L + p.xs.t(t.value) * w;
      right = std::max(right, x + text.width(t.label, kTickPx) / 2 - R + pad);
    }
    if (p.cbar.on) right = colorbar_width(text, p.cbar, h) + pad;
    const double left = pad + (a.ylabel.empty() ? 0 : kLabelPx + 10) + p.ytick_w + 4 + kTickLen;
    // Room for a "×10^k" above the y axis or colour bar, and below the x tick labels.
    const bool mult_above = !p.ymult.empty() || (p.cbar.on && !p.cbar.mult.empty());
    const double top_now = std::max(top, mult_above ? pad + kTickPx + 8 : 0.0);
    const double bottom_now = a.xlabel.empty() && !p.xmult.empty() ? bottom + 10 + kTickPx : bottom;
    L = cx0 + left;
    R = cx1 - right;
    T = cy0 + top_now;
    B = cy1 - bottom_now;
    if (R - L < 20) R = L + 20;
    if (B - T < 20) B = T + 20;
  }
  p.L = std::round(L), p.R = std::round(R), p.T = std::round(T), p.B = std::round(B);
  if (a.equal && !p.xs.log && !p.ys.log) {
    // Exactly equal scales on the final (whole-pixel) rectangle.
    const double ux = (p.xs.hi - p.xs.lo) / (p.R - p.L), uy = (p.ys.hi - p.ys.lo) / (p.B - p.T);
    if (ux > uy) {
      const double c = (p.ys.lo + p.ys.hi) / 2, half = ux * (p.B - p.T) / 2;
      p.ys.lo = c - half, p.ys.hi = c + half;
    } else {
      const double c = (p.xs.lo + p.xs.hi) / 2, half = uy * (p.R - p.L) / 2;
      p.xs.lo = c - half, p.xs.hi = c + half;
    }
  }
  p.xs.p0 = p.L, p.xs.p1 = p.R;
  p.ys.p0 = p.B, p.ys.p1 = p.T;
  if (p.cbar.on) {
    p.cbar.L = p.R + kBarGap;
    p.cbar.R = p.cbar.L + kBarWidth;
    p.cbar.T = p.T;
    p.cbar.B = p.B;
  }
  return p;
}

}  // namespace pvdf::plot::detail
