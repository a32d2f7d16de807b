// Internal: drawing one panel on a Cairo context (draw.cpp).
#pragma once

#include "layout.hpp"

namespace pvdf::plot::detail {

/// Draws panels and colour bars on `cr` in PNG pixel coordinates (the caller scales vector
/// surfaces), text through `text`.
class PanelPainter {
 public:
  PanelPainter(cairo_t* cr, TextEngine& text) : cr_(cr), text_(text) {}
  void draw_panel(const Axes::Impl& a, const PanelLayout& p);
  /// A colour bar in its rectangle [L, R] × [T, B] (triangles for extends go inside it).
  void draw_colorbar(const ColorBar& cb);

 private:
  void set_color(Color c);
  void stroke_polyline(const std::vector<P2>& pts, double width, Color c, LineStyle style, bool closed = false);
  void segment(P2 a, P2 b, double width, Color c);
  void marker(P2 q, Marker m, double size, Color c);
  void fill_polygon(const std::vector<P2>& pts, Color c);
  void draw_field(const Item& it, const PanelLayout& p, bool log, const std::vector<P2>& domain, double inset);
  void draw_line(const Item& it, const PanelLayout& p, std::vector<P2>& pts);
  void draw_error_bars(const Item& it, const PanelLayout& p, std::vector<P2>& pts);
  void draw_polygon(const Item& it, const PanelLayout& p, std::vector<P2>& pts);
  void draw_contour(const Item& it, const PanelLayout& p, std::vector<P2>& pts);
  void draw_frame_and_ticks(const Axes::Impl& a, const PanelLayout& p);
  void draw_legend(const Axes::Impl& a, const PanelLayout& p, const std::vector<P2>& data_points);

  cairo_t* cr_;
  TextEngine& text_;
  std::vector<std::array<double, 4>> placed_labels_;  // contour label boxes of the panel (cx, cy, hw, hh)
  std::array<double, 4> clip_box_{};
  struct PendingLabel {
    double x, y;
    std::string text;
    Color color;
    double angle_deg;
  };
  std::vector<PendingLabel> pending_labels_;  // contour labels, drawn after the panel's items
  struct LinePoint {
    double x, y;
    std::size_t line;
  };
  std::vector<LinePoint> line_points_;  // every contour line of the panel, sampled every ~3 px
  std::size_t line_counter_ = 0;        // which contour line draw_contour is at                  // far box against which geometry is clipped
};

}  // namespace pvdf::plot::detail
