// The PNG renderer behind pvdf::plot: geometry (lines, markers, polygons, fields) is filled by a
// nonzero-winding scanline rasterizer on a 3× supersampled canvas and box-filtered down (that is
// the anti-aliasing); text is drawn afterwards on the final image through FreeType, so glyphs stay
// hinted and crisp. PNG output uses libpng's simplified API inside pvdf::write_path_atomically.
#include "pvdf/core/plot.hpp"

#include "pvdf/core/error.hpp"
#include "pvdf/core/io.hpp"

#include <ft2build.h>
#include FT_FREETYPE_H
#include <png.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <limits>
#include <map>
#include <memory>
#include <tuple>
#include <unordered_map>

namespace pvdf::plot {
namespace {

using P2 = std::array<double, 2>;
constexpr double kPi = 3.14159265358979323846;
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
const char* const kFontPath = "/usr/share/fonts/truetype/dejavu/DejaVuSans.ttf";
const char* const kBoldFontPath = "/usr/share/fonts/truetype/dejavu/DejaVuSans-Bold.ttf";

// Font sizes in pixels of the final image.
constexpr double kTickPx = 12, kLabelPx = 13, kTitlePx = 15, kSupTitlePx = 17, kLegendPx = 12, kContourPx = 11;
constexpr double kTickLen = 5;  // outward tick marks, px
const Color kBlack{0, 0, 0}, kWhite{255, 255, 255}, kFrame{40, 40, 40}, kGrid{222, 222, 222};

bool finite(double v) { return std::isfinite(v); }

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

// ---------------------------------------------------------------------------------------------
// UTF-8 → code points (invalid bytes become U+FFFD), so labels may say "µm", "β" or "m²".
std::vector<char32_t> utf8_decode(const std::string& s) {
  std::vector<char32_t> out;
  for (std::size_t i = 0; i < s.size();) {
    const auto c = static_cast<unsigned char>(s[i]);
    int n = 0;
    char32_t cp = 0;
    if (c < 0x80) { cp = c; n = 0; }
    else if ((c >> 5) == 0x6) { cp = c & 0x1F; n = 1; }
    else if ((c >> 4) == 0xE) { cp = c & 0x0F; n = 2; }
    else if ((c >> 3) == 0x1E) { cp = c & 0x07; n = 3; }
    else { out.push_back(0xFFFD); ++i; continue; }
    if (n > 0 && i + n >= s.size()) { out.push_back(0xFFFD); break; }
    bool ok = true;
    for (int k = 1; k <= n; ++k) {
      const auto d = static_cast<unsigned char>(s[i + k]);
      if ((d >> 6) != 0x2) { ok = false; break; }
      cp = (cp << 6) | (d & 0x3F);
    }
    if (!ok) { out.push_back(0xFFFD); ++i; continue; }
    out.push_back(cp);
    i += n + 1;
  }
  return out;
}

// ---------------------------------------------------------------------------------------------
// The final RGB image (text is blended into it).
struct Image {
  int w = 0, h = 0;
  std::vector<unsigned char> rgb;
  void blend(int x, int y, Color c, double a) {
    if (x < 0 || y < 0 || x >= w || y >= h || a <= 0) return;
    a = std::min(a, 1.0);
    unsigned char* p = &rgb[(static_cast<std::size_t>(y) * w + x) * 3];
    p[0] = static_cast<unsigned char>(std::lround(p[0] + (c.r - p[0]) * a));
    p[1] = static_cast<unsigned char>(std::lround(p[1] + (c.g - p[1]) * a));
    p[2] = static_cast<unsigned char>(std::lround(p[2] + (c.b - p[2]) * a));
  }
};

enum class VAlign { top, center, baseline, bottom };

// FreeType faces (DejaVu Sans regular and bold) with cached advances for measuring.
class Fonts {
 public:
  Fonts() {
    if (!std::ifstream(kFontPath).good()) {
      throw InputError(std::string("plot font ") + kFontPath +
                       " is missing; install the Debian package fonts-dejavu-core (apt-get install fonts-dejavu-core)");
    }
    if (FT_Init_FreeType(&lib_) != 0) throw InputError("FreeType could not be initialised; reinstall libfreetype6");
    if (FT_New_Face(lib_, kFontPath, 0, &regular_) != 0) {
      FT_Done_FreeType(lib_);
      throw InputError(std::string("plot font ") + kFontPath +
                       " cannot be read by FreeType; reinstall fonts-dejavu-core");
    }
    if (std::ifstream(kBoldFontPath).good() && FT_New_Face(lib_, kBoldFontPath, 0, &bold_) != 0) bold_ = nullptr;
  }
  ~Fonts() {
    if (bold_) FT_Done_Face(bold_);
    FT_Done_Face(regular_);
    FT_Done_FreeType(lib_);
  }
  Fonts(const Fonts&) = delete;
  Fonts& operator=(const Fonts&) = delete;

  /// Width of `s` (which may hold $...$ math, see parse_math) at `px` pixels, unrotated.
  double width(const std::string& s, double px, bool bold = false) {
    double w = 0;
    for (const auto& run : parse_math(s)) w += plain_width(run.text, px * run.scale, bold);
    return w;
  }

  /// Draws `s` so that the anchor (halign 0/0.5/1 of its width, valign) lands on (x, y), rotated
  /// counter-clockwise by angle_deg about the anchor.
  void draw(Image& img, double x, double y, const std::string& s, double px, Color c, double angle_deg = 0,
            double halign = 0, VAlign valign = VAlign::baseline, bool bold = false) {
    if (s.empty() || !(std::abs(x) < 1e6) || !(std::abs(y) < 1e6)) return;
    const auto runs = parse_math(s);
    double w = 0;
    for (const auto& run : runs) w += plain_width(run.text, px * run.scale, bold);
    double v = 0;
    switch (valign) {
      case VAlign::top: v = 0.73 * px; break;
      case VAlign::center: v = 0.365 * px; break;
      case VAlign::baseline: v = 0; break;
      case VAlign::bottom: v = -0.236 * px; break;
    }
    const double th = angle_deg * kPi / 180, cs = std::cos(th), sn = std::sin(th);
    // Text-frame point (u along the baseline, v up) → screen offset from the anchor.
    auto screen = [&](double u, double vv) { return P2{u * cs - vv * sn, -(u * sn + vv * cs)}; };
    const P2 origin = screen(-halign * w, -v);
    double u = 0;
    for (const auto& run : runs) {
      const P2 o = screen(u, run.shift_em * px);
      draw_run(img, x + origin[0] + o[0], y + origin[1] + o[1], run.text, px * run.scale, c, angle_deg, bold);
      u += plain_width(run.text, px * run.scale, bold);
    }
  }

 private:
  /// A piece of text at one size and baseline: plain text, a subscript or a superscript.
  struct Run {
    std::string text;
    double scale = 1, shift_em = 0;
  };

  /// Minimal math markup inside $...$: x_i, x_{ij}, x^2, x^{-1}, and \name for Greek letters and
  /// a few symbols (\nu, \sigma, \mu, \Delta, \times, \pm, \cdot, \circ ...). Text outside
  /// $...$, or with an unpaired $, is drawn as it is.
  static std::vector<Run> parse_math(const std::string& s) {
    const auto n_dollar = std::count(s.begin(), s.end(), '$');
    if (n_dollar == 0 || n_dollar % 2 != 0) return {Run{s}};
    std::vector<Run> runs;
    auto add = [&](const std::string& text, double scale, double shift) {
      if (text.empty()) return;
      if (!runs.empty() && runs.back().scale == scale && runs.back().shift_em == shift) runs.back().text += text;
      else runs.push_back({text, scale, shift});
    };
    bool math = false;
    for (std::size_t i = 0; i < s.size();) {
      if (s[i] == '$') {
        math = !math;
        ++i;
        continue;
      }
      if (!math) {
        add(std::string(1, s[i]), 1, 0);
        ++i;
        continue;
      }
      if (s[i] == '_' || s[i] == '^') {
        const bool sub = s[i] == '_';
        ++i;
        std::string body;
        if (i < s.size() && s[i] == '{') {
          const std::size_t close = s.find('}', i);
          const std::size_t end = close == std::string::npos ? s.size() : close;
          body = s.substr(i + 1, end - i - 1);
          i = end == s.size() ? end : end + 1;
        } else if (i < s.size() && s[i] == '\\') {
          std::size_t k = i + 1;
          while (k < s.size() && std::isalpha(static_cast<unsigned char>(s[k]))) ++k;
          body = s.substr(i, k - i);
          i = k;
        } else if (i < s.size() && s[i] != '$') {
          std::size_t k = i + 1;  // one UTF-8 code point
          while (k < s.size() && (static_cast<unsigned char>(s[k]) & 0xC0) == 0x80) ++k;
          body = s.substr(i, k - i);
          i = k;
        }
        add(symbols(body), 0.7, sub ? -0.2 : 0.42);
        continue;
      }
      if (s[i] == '\\') {
        std::size_t k = i + 1;
        while (k < s.size() && std::isalpha(static_cast<unsigned char>(s[k]))) ++k;
        if (k == i + 1 && k < s.size()) ++k;  // \$ or \\ and the like
        add(symbols(s.substr(i, k - i)), 1, 0);
        i = k;
        continue;
      }
      add(std::string(1, s[i]), 1, 0);
      ++i;
    }
    if (runs.empty()) runs.push_back(Run{});
    return runs;
  }

  /// Replaces \name commands by their Unicode characters; unknown names stay as written.
  static std::string symbols(const std::string& t) {
    static const std::map<std::string, std::string> table = {
        {"alpha", "\u03B1"},   {"beta", "\u03B2"},    {"gamma", "\u03B3"},  {"delta", "\u03B4"},
        {"epsilon", "\u03B5"}, {"varepsilon", "\u03B5"}, {"zeta", "\u03B6"}, {"eta", "\u03B7"},
        {"theta", "\u03B8"},   {"kappa", "\u03BA"},   {"lambda", "\u03BB"}, {"mu", "\u03BC"},
        {"nu", "\u03BD"},      {"xi", "\u03BE"},      {"pi", "\u03C0"},     {"rho", "\u03C1"},
        {"sigma", "\u03C3"},   {"tau", "\u03C4"},     {"phi", "\u03C6"},    {"varphi", "\u03C6"},
        {"chi", "\u03C7"},     {"psi", "\u03C8"},     {"omega", "\u03C9"},  {"Gamma", "\u0393"},
        {"Delta", "\u0394"},   {"Theta", "\u0398"},   {"Lambda", "\u039B"}, {"Pi", "\u03A0"},
        {"Sigma", "\u03A3"},   {"Phi", "\u03A6"},     {"Psi", "\u03A8"},    {"Omega", "\u03A9"},
        {"times", "\u00D7"},   {"cdot", "\u00B7"},    {"pm", "\u00B1"},     {"circ", "\u00B0"},
        {"infty", "\u221E"},   {"partial", "\u2202"}, {"approx", "\u2248"}, {"le", "\u2264"},
        {"leq", "\u2264"},     {"ge", "\u2265"},      {"geq", "\u2265"},    {"sqrt", "\u221A"},
        {"nabla", "\u2207"},   {"$", "$"},             {"\\", "\\"},         {"_", "_"},
        {"%", "%"},             {"{", "{"},             {"}", "}"},
        {",", "\u2009"},       {";", " "},             {"!", ""},             {" ", " "}};
    std::string out;
    for (std::size_t i = 0; i < t.size();) {
      if (t[i] != '\\') {
        out += t[i++];
        continue;
      }
      std::size_t k = i + 1;
      while (k < t.size() && std::isalpha(static_cast<unsigned char>(t[k]))) ++k;
      if (k == i + 1 && k < t.size()) ++k;
      const auto it = table.find(t.substr(i + 1, k - i - 1));
      out += it != table.end() ? it->second : t.substr(i, k - i);
      i = k;
    }
    return out;
  }

  double plain_width(const std::string& s, double px, bool bold) {
    double w = 0;
    for (char32_t cp : utf8_decode(s)) w += advance(cp, px, bold);
    return w;
  }

  /// Glyphs of `s` from the pen position (x, y) on the baseline, rotated by angle_deg.
  void draw_run(Image& img, double x, double y, const std::string& s, double px, Color c, double angle_deg,
                bool bold) {
    if (s.empty()) return;
    FT_Face f = face(bold);
    set_size(f, px);
    const double th = angle_deg * kPi / 180, cs = std::cos(th), sn = std::sin(th);
    const bool upright = angle_deg == 0;
    double penx = upright ? std::round(x) : x, peny = upright ? std::round(y) : y;
    const bool hint = upright || angle_deg == 90;
    FT_Matrix m;
    m.xx = static_cast<FT_Fixed>(std::lround(cs * 65536));
    m.xy = static_cast<FT_Fixed>(std::lround(-sn * 65536));
    m.yx = static_cast<FT_Fixed>(std::lround(sn * 65536));
    m.yy = static_cast<FT_Fixed>(std::lround(cs * 65536));
    for (char32_t cp : utf8_decode(s)) {
      const double ix = std::floor(penx), iy = std::floor(peny);
      FT_Vector delta;
      delta.x = static_cast<FT_Pos>(std::lround((penx - ix) * 64));
      delta.y = static_cast<FT_Pos>(std::lround(-(peny - iy) * 64));
      FT_Set_Transform(f, upright ? nullptr : &m, &delta);
      const FT_UInt idx = FT_Get_Char_Index(f, cp);
      if (FT_Load_Glyph(f, idx, hint ? FT_LOAD_DEFAULT : FT_LOAD_NO_HINTING) != 0) continue;
      FT_GlyphSlot g = f->glyph;
      if (FT_Render_Glyph(g, FT_RENDER_MODE_NORMAL) == 0) {
        const FT_Bitmap& bm = g->bitmap;
        const int x0 = static_cast<int>(ix) + g->bitmap_left, y0 = static_cast<int>(iy) - g->bitmap_top;
        const int pitch = std::abs(bm.pitch);
        for (unsigned r = 0; r < bm.rows; ++r) {
          for (unsigned col = 0; col < bm.width; ++col) {
            const unsigned char a = bm.buffer[r * pitch + col];
            if (a) img.blend(x0 + static_cast<int>(col), y0 + static_cast<int>(r), c, a / 255.0);
          }
        }
      }
      penx += g->advance.x / 64.0;
      peny -= g->advance.y / 64.0;
    }
    FT_Set_Transform(f, nullptr, nullptr);
  }

  FT_Face face(bool bold) const { return bold && bold_ ? bold_ : regular_; }
  static void set_size(FT_Face f, double px) {
    FT_Set_Char_Size(f, 0, static_cast<FT_F26Dot6>(std::lround(px * 64)), 72, 72);
  }
  double advance(char32_t cp, double px, bool bold) {
    const auto key = std::make_tuple(static_cast<std::uint32_t>(cp), std::lround(px * 64), bold);
    const auto it = cache_.find(key);
    if (it != cache_.end()) return it->second;
    FT_Face f = face(bold);
    set_size(f, px);
    FT_Set_Transform(f, nullptr, nullptr);
    double a = 0;
    if (FT_Load_Glyph(f, FT_Get_Char_Index(f, cp), FT_LOAD_DEFAULT) == 0) a = f->glyph->advance.x / 64.0;
    cache_[key] = a;
    return a;
  }
  FT_Library lib_ = nullptr;
  FT_Face regular_ = nullptr, bold_ = nullptr;
  std::map<std::tuple<std::uint32_t, long, bool>, double> cache_;
};

/// A tick label: base text and an optional superscript (for "10^k" and "×10^k").
struct Label {
  std::string base, sup;
};

double label_width(Fonts& fonts, const Label& l, double px) {
  return fonts.width(l.base, px) + (l.sup.empty() ? 0 : fonts.width(l.sup, 0.72 * px) + 1);
}

void draw_label(Fonts& fonts, Image& img, double x, double y, const Label& l, double px, Color c, double halign,
                VAlign valign) {
  const double w = label_width(fonts, l, px);
  const double left = x - halign * w;
  fonts.draw(img, left, y, l.base, px, c, 0, 0, valign);
  if (!l.sup.empty()) {
    double base_y = y;
    if (valign == VAlign::top) base_y = y + 0.73 * px;
    if (valign == VAlign::center) base_y = y + 0.365 * px;
    if (valign == VAlign::bottom) base_y = y - 0.236 * px;
    fonts.draw(img, left + fonts.width(l.base, px) + 1, base_y - 0.42 * px, l.sup, 0.72 * px, c);
  }
}

// ---------------------------------------------------------------------------------------------
// Supersampled canvas: every primitive is a nonzero-winding polygon filled by scanlines at
// sample centres, clipped to a rectangle. Colours are opaque, so overlapping pieces of one
// stroke (segment quads and round joins) paint the same samples without double blending.
class Raster {
 public:
  Raster(int w, int h, int ss) : ss_(ss), W_(w * ss), H_(h * ss), px_(static_cast<std::size_t>(W_) * H_ * 3, 255) {
    reset_clip();
  }
  int ss() const { return ss_; }

  /// Clip to the final-pixel rectangle [x0, x1) × [y0, y1).
  void set_clip(double x0, double y0, double x1, double y1) {
    cx0_ = std::clamp(static_cast<int>(std::lround(x0 * ss_)), 0, W_);
    cy0_ = std::clamp(static_cast<int>(std::lround(y0 * ss_)), 0, H_);
    cx1_ = std::clamp(static_cast<int>(std::lround(x1 * ss_)), 0, W_);
    cy1_ = std::clamp(static_cast<int>(std::lround(y1 * ss_)), 0, H_);
  }
  void reset_clip() { cx0_ = 0, cy0_ = 0, cx1_ = W_, cy1_ = H_; }
  std::array<double, 4> clip() const {
    return {static_cast<double>(cx0_) / ss_, static_cast<double>(cy0_) / ss_, static_cast<double>(cx1_) / ss_,
            static_cast<double>(cy1_) / ss_};
  }

  void fill_polygon(const std::vector<P2>& pts, Color c) {
    if (pts.size() < 3) return;
    double minx = pts[0][0], maxx = minx, miny = pts[0][1], maxy = miny;
    for (const auto& p : pts) {
      if (!finite(p[0]) || !finite(p[1])) return;
      minx = std::min(minx, p[0]), maxx = std::max(maxx, p[0]);
      miny = std::min(miny, p[1]), maxy = std::max(maxy, p[1]);
    }
    const auto cl = clip();
    if (maxx < cl[0] || minx > cl[2] || maxy < cl[1] || miny > cl[3]) return;
    // Far outside the clip box: cut the polygon down first so the arithmetic stays small.
    const double margin = 4;
    if (minx < cl[0] - margin || maxx > cl[2] + margin || miny < cl[1] - margin || maxy > cl[3] + margin) {
      const auto cut = clip_polygon(pts, cl[0] - margin, cl[1] - margin, cl[2] + margin, cl[3] + margin);
      fill_clipped(cut, c);
    } else {
      fill_clipped(pts, c);
    }
  }

  void fill_rect(double x0, double y0, double x1, double y1, Color c) {
    fill_polygon({{x0, y0}, {x1, y0}, {x1, y1}, {x0, y1}}, c);
  }

  void fill_circle(P2 center, double r, Color c) {
    if (r <= 0) return;
    const int n = std::clamp(static_cast<int>(r * ss_ * 1.2) + 8, 8, 64);
    std::vector<P2> pts(n);
    for (int k = 0; k < n; ++k) {
      const double a = 2 * kPi * k / n;
      pts[k] = {center[0] + r * std::cos(a), center[1] + r * std::sin(a)};
    }
    fill_polygon(pts, c);
  }

  /// A straight segment of width w (butt ends).
  void stroke_segment(P2 a, P2 b, double w, Color c) {
    const auto cl = clip();
    if (!clip_segment(a, b, cl[0] - w - 2, cl[1] - w - 2, cl[2] + w + 2, cl[3] + w + 2)) return;
    const double dx = b[0] - a[0], dy = b[1] - a[1], len = std::hypot(dx, dy);
    if (!(len > 1e-9)) return;
    const double nx = -dy / len * w / 2, ny = dx / len * w / 2;
    fill_polygon({{a[0] + nx, a[1] + ny}, {b[0] + nx, b[1] + ny}, {b[0] - nx, b[1] - ny}, {a[0] - nx, a[1] - ny}}, c);
  }

  /// A polyline of finite points with round joins, dashed or dotted as asked.
  void stroke_polyline(std::vector<P2> pts, double w, Color c, LineStyle style, bool closed = false) {
    if (style == LineStyle::none || pts.empty()) return;
    w = std::max(w, 0.5);
    if (closed && pts.size() > 2) pts.push_back(pts.front());
    if (style == LineStyle::solid) {
      stroke_run(pts, w, c, closed);
      return;
    }
    const auto cum = cumulative_length(pts);
    const double total = cum.back();
    if (style == LineStyle::dotted) {
      const double spacing = std::max(2.6 * w, 3.5), r = std::max(w / 2, 0.75);
      for (double s = 0; s <= total + 1e-9; s += spacing) fill_circle(point_at(pts, cum, s), r, c);
      return;
    }
    const double unit = std::max(w, 1.5), on = 3.7 * unit, off = 1.6 * unit;
    std::vector<std::pair<double, double>> keep;
    for (double s = 0; s < total; s += on + off) keep.emplace_back(s, std::min(s + on, total));
    for (const auto& run : cut_polyline(pts, cum, keep)) stroke_run(run, w, c, false);
  }

  void marker(P2 p, Marker m, double size, Color c) {
    if (!finite(p[0]) || !finite(p[1]) || m == Marker::none) return;
    const double r = std::max(size, 1.0) / 2;
    const double lw = std::max(1.5, size / 4);
    switch (m) {
      case Marker::circle: fill_circle(p, r, c); break;
      case Marker::square: fill_rect(p[0] - 0.85 * r, p[1] - 0.85 * r, p[0] + 0.85 * r, p[1] + 0.85 * r, c); break;
      case Marker::triangle:
        fill_polygon({{p[0], p[1] - 1.15 * r}, {p[0] + r, p[1] + 0.6 * r}, {p[0] - r, p[1] + 0.6 * r}}, c);
        break;
      case Marker::cross:
        stroke_segment({p[0] - r, p[1] - r}, {p[0] + r, p[1] + r}, lw, c);
        stroke_segment({p[0] - r, p[1] + r}, {p[0] + r, p[1] - r}, lw, c);
        break;
      case Marker::plus:
        stroke_segment({p[0] - r, p[1]}, {p[0] + r, p[1]}, lw, c);
        stroke_segment({p[0], p[1] - r}, {p[0], p[1] + r}, lw, c);
        break;
      case Marker::none: break;
    }
  }

  /// Paints every sample of the final-pixel rectangle [x0, x1) × [y0, y1) (within the clip)
  /// with colour(sample x, sample y) in final-pixel coordinates; a colour function returning
  /// false leaves the sample alone.
  template <class F>
  void shade(double x0, double y0, double x1, double y1, F&& colour) {
    const int i0 = std::max(cx0_, static_cast<int>(std::ceil(x0 * ss_ - 0.5)));
    const int i1 = std::min(cx1_, static_cast<int>(std::ceil(x1 * ss_ - 0.5)));
    const int j0 = std::max(cy0_, static_cast<int>(std::ceil(y0 * ss_ - 0.5)));
    const int j1 = std::min(cy1_, static_cast<int>(std::ceil(y1 * ss_ - 0.5)));
    for (int j = j0; j < j1; ++j) {
      unsigned char* row = &px_[static_cast<std::size_t>(j) * W_ * 3];
      for (int i = i0; i < i1; ++i) {
        Color c;
        if (colour(i, j, c)) {
          row[3 * i] = c.r, row[3 * i + 1] = c.g, row[3 * i + 2] = c.b;
        }
      }
    }
  }

  void downsample(Image& out) const {
    out.w = W_ / ss_, out.h = H_ / ss_;
    out.rgb.assign(static_cast<std::size_t>(out.w) * out.h * 3, 0);
    const int n = ss_ * ss_;
    for (int y = 0; y < out.h; ++y) {
      for (int x = 0; x < out.w; ++x) {
        int sum[3] = {0, 0, 0};
        for (int sy = 0; sy < ss_; ++sy) {
          const unsigned char* p = &px_[(static_cast<std::size_t>(y * ss_ + sy) * W_ + x * ss_) * 3];
          for (int sx = 0; sx < ss_; ++sx) sum[0] += p[3 * sx], sum[1] += p[3 * sx + 1], sum[2] += p[3 * sx + 2];
        }
        unsigned char* q = &out.rgb[(static_cast<std::size_t>(y) * out.w + x) * 3];
        for (int k = 0; k < 3; ++k) q[k] = static_cast<unsigned char>((sum[k] + n / 2) / n);
      }
    }
  }

  static std::vector<double> cumulative_length(const std::vector<P2>& pts) {
    std::vector<double> cum(pts.size(), 0.0);
    for (std::size_t i = 1; i < pts.size(); ++i)
      cum[i] = cum[i - 1] + std::hypot(pts[i][0] - pts[i - 1][0], pts[i][1] - pts[i - 1][1]);
    return cum;
  }
  static P2 point_at(const std::vector<P2>& pts, const std::vector<double>& cum, double s) {
    if (pts.size() == 1 || s <= 0) return pts.front();
    if (s >= cum.back()) return pts.back();
    const std::size_t k = static_cast<std::size_t>(std::upper_bound(cum.begin(), cum.end(), s) - cum.begin());
    const std::size_t i = std::clamp<std::size_t>(k, 1, pts.size() - 1);
    const double seg = cum[i] - cum[i - 1];
    const double t = seg > 0 ? (s - cum[i - 1]) / seg : 0;
    return {pts[i - 1][0] + t * (pts[i][0] - pts[i - 1][0]), pts[i - 1][1] + t * (pts[i][1] - pts[i - 1][1])};
  }
  /// The pieces of a polyline whose arc length lies in the sorted intervals `keep`.
  static std::vector<std::vector<P2>> cut_polyline(const std::vector<P2>& pts, const std::vector<double>& cum,
                                                   const std::vector<std::pair<double, double>>& keep) {
    std::vector<std::vector<P2>> runs;
    for (const auto& [a, b] : keep) {
      if (!(b > a)) continue;
      std::vector<P2> run{point_at(pts, cum, a)};
      auto it = std::upper_bound(cum.begin(), cum.end(), a);
      for (; it != cum.end() && *it < b; ++it) run.push_back(pts[static_cast<std::size_t>(it - cum.begin())]);
      run.push_back(point_at(pts, cum, b));
      runs.push_back(std::move(run));
    }
    return runs;
  }

 private:
  void stroke_run(const std::vector<P2>& pts, double w, Color c, bool closed) {
    if (pts.size() == 1) return;
    const bool joins = w >= 1.4;
    for (std::size_t i = 1; i < pts.size(); ++i) {
      stroke_segment(pts[i - 1], pts[i], w, c);
      if (joins && (i + 1 < pts.size() || closed)) fill_circle(pts[i], w / 2, c);
    }
  }

  // Liang–Barsky: clips segment a-b to the box; false if nothing is left.
  static bool clip_segment(P2& a, P2& b, double x0, double y0, double x1, double y1) {
    if (!finite(a[0]) || !finite(a[1]) || !finite(b[0]) || !finite(b[1])) return false;
    double t0 = 0, t1 = 1;
    const double dx = b[0] - a[0], dy = b[1] - a[1];
    const double p[4] = {-dx, dx, -dy, dy};
    const double q[4] = {a[0] - x0, x1 - a[0], a[1] - y0, y1 - a[1]};
    for (int k = 0; k < 4; ++k) {
      if (p[k] == 0) {
        if (q[k] < 0) return false;
      } else {
        const double t = q[k] / p[k];
        if (p[k] < 0) t0 = std::max(t0, t);
        else t1 = std::min(t1, t);
      }
    }
    if (t0 > t1) return false;
    const P2 a0 = a;
    a = {a0[0] + t0 * dx, a0[1] + t0 * dy};
    b = {a0[0] + t1 * dx, a0[1] + t1 * dy};
    return true;
  }

  // Sutherland–Hodgman against an axis-aligned box.
  static std::vector<P2> clip_polygon(const std::vector<P2>& in, double x0, double y0, double x1, double y1) {
    std::vector<P2> cur = in, next;
    for (int side = 0; side < 4; ++side) {
      next.clear();
      auto inside = [&](const P2& p) {
        switch (side) {
          case 0: return p[0] >= x0;
          case 1: return p[0] <= x1;
          case 2: return p[1] >= y0;
          default: return p[1] <= y1;
        }
      };
      auto cross = [&](const P2& p, const P2& q) {
        const double edge = side == 0 ? x0 : side == 1 ? x1 : side == 2 ? y0 : y1;
        const int axis = side < 2 ? 0 : 1;
        const double t = (edge - p[axis]) / (q[axis] - p[axis]);
        return P2{p[0] + t * (q[0] - p[0]), p[1] + t * (q[1] - p[1])};
      };
      for (std::size_t i = 0; i < cur.size(); ++i) {
        const P2& p = cur[i];
        const P2& q = cur[(i + 1) % cur.size()];
        const bool ip = inside(p), iq = inside(q);
        if (ip) next.push_back(p);
        if (ip != iq) next.push_back(cross(p, q));
      }
      cur.swap(next);
      if (cur.empty()) break;
    }
    return cur;
  }

  struct Edge {
    double x0, y0, x1, y1;
    int dir;
  };

  void fill_clipped(const std::vector<P2>& pts, Color c) {
    if (pts.size() < 3) return;
    edges_.clear();
    double miny = std::numeric_limits<double>::infinity(), maxy = -miny;
    for (std::size_t i = 0; i < pts.size(); ++i) {
      const P2& p = pts[i];
      const P2& q = pts[(i + 1) % pts.size()];
      const double y0 = p[1] * ss_, y1 = q[1] * ss_;
      if (y0 == y1) continue;
      if (y0 < y1) edges_.push_back({p[0] * ss_, y0, q[0] * ss_, y1, 1});
      else edges_.push_back({q[0] * ss_, y1, p[0] * ss_, y0, -1});
      miny = std::min({miny, y0, y1});
      maxy = std::max({maxy, y0, y1});
    }
    if (edges_.empty()) return;
    const int j0 = std::max(cy0_, static_cast<int>(std::ceil(miny - 0.5)));
    const int j1 = std::min(cy1_ - 1, static_cast<int>(std::ceil(maxy - 0.5)) - 1);
    for (int j = j0; j <= j1; ++j) {
      const double yc = j + 0.5;
      xs_.clear();
      for (const Edge& e : edges_) {
        if (yc >= e.y0 && yc < e.y1) xs_.emplace_back(e.x0 + (yc - e.y0) * (e.x1 - e.x0) / (e.y1 - e.y0), e.dir);
      }
      if (xs_.size() < 2) continue;
      std::sort(xs_.begin(), xs_.end());
      unsigned char* row = &px_[static_cast<std::size_t>(j) * W_ * 3];
      int winding = 0;
      double start = 0;
      for (const auto& [x, dir] : xs_) {
        const int before = winding;
        winding += dir;
        if (before == 0 && winding != 0) {
          start = x;
        } else if (before != 0 && winding == 0) {
          const int i0 = std::max(cx0_, static_cast<int>(std::ceil(start - 0.5)));
          const int i1 = std::min(cx1_, static_cast<int>(std::ceil(x - 0.5)));
          for (int i = i0; i < i1; ++i) row[3 * i] = c.r, row[3 * i + 1] = c.g, row[3 * i + 2] = c.b;
        }
      }
    }
  }

  int ss_, W_, H_;
  std::vector<unsigned char> px_;
  int cx0_ = 0, cy0_ = 0, cx1_ = 0, cy1_ = 0;
  std::vector<Edge> edges_;
  std::vector<std::pair<double, int>> xs_;
};

// ---------------------------------------------------------------------------------------------
// Axis scales and ticks.

struct Scale {
  double lo = 0, hi = 1;
  bool log = false;
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
  Label label;
  bool major = true;
};

std::string with_minus_sign(std::string s) {
  if (!s.empty() && s[0] == '-') s = "\xE2\x88\x92" + s.substr(1);  // U+2212 MINUS SIGN
  return s;
}

double nice_step(double range, int target) {
  const double raw = range / std::max(target, 1);
  if (!(raw > 0) || !finite(raw)) return 0;
  const double mag = std::pow(10.0, std::floor(std::log10(raw)));
  const double f = raw / mag;
  return (f <= 1.0001 ? 1 : f <= 2.0001 ? 2 : f <= 5.0001 ? 5 : 10) * mag;
}

/// 1-2-5 ticks within [lo, hi], about `target` of them, labelled with just enough decimals.
/// Very large or small values are labelled by mantissas and one common `multiplier` ("×10^k",
/// empty otherwise); without a `multiplier` to fill, each label carries its own power of ten.
std::vector<Tick> linear_ticks(double lo, double hi, int target, Label* multiplier = nullptr) {
  if (multiplier) *multiplier = Label{};
  std::vector<Tick> ticks;
  // The smallest 1-2-5 step that leaves at most `target` intervals between the ticks inside.
  double step = nice_step(hi - lo, target);
  if (!(step > 0)) return ticks;
  for (int k = 0; k < 3; ++k) {
    const double m = step / std::pow(10.0, std::floor(std::log10(step) + 1e-9));
    const double smaller = step * (m < 1.5 ? 0.5 : m < 3 ? 0.5 : 0.4);  // 1→0.5, 2→1, 5→2
    if (std::floor(hi / smaller + 1e-9) - std::ceil(lo / smaller - 1e-9) > target) break;
    step = smaller;
  }
  const double k0 = std::ceil(lo / step - 1e-9), k1 = std::floor(hi / step + 1e-9);
  if (!finite(k0) || !finite(k1) || k1 - k0 > 200) return ticks;
  const double maxabs = std::max(std::abs(lo), std::abs(hi));
  const bool sci = maxabs >= 1e5 || maxabs < 1e-3;
  int exponent = 0;
  double unit = 1;
  if (sci && maxabs > 0) {
    exponent = static_cast<int>(std::floor(std::log10(maxabs)));
    unit = std::pow(10.0, exponent);
  }
  const int decimals = std::clamp(static_cast<int>(-std::floor(std::log10(step / unit) + 1e-9)), 0, 12);
  for (double k = k0; k <= k1; k += 1) {
    double v = k * step;
    if (std::abs(v) < step * 1e-9) v = 0;
    char buf[64];
    std::snprintf(buf, sizeof buf, "%.*f", decimals, v / unit);
    Tick t;
    t.value = v;
    if (sci && multiplier) {
      t.label.base = v == 0 ? "0" : with_minus_sign(buf);
      *multiplier = Label{"\xC3\x97" "10", with_minus_sign(std::to_string(exponent))};  // ×10^k
    } else if (sci && v != 0) {
      t.label.base = with_minus_sign(buf) + "\xC3\x97" "10";  // ×10
      t.label.sup = with_minus_sign(std::to_string(exponent));
    } else {
      t.label.base = sci ? "0" : with_minus_sign(buf);
      if (t.label.base == "\xE2\x88\x92" "0") t.label.base = "0";
    }
    ticks.push_back(t);
  }
  return ticks;
}

/// Decade ticks 10^k (every `stride` decades) with minor ticks at 2..9 × 10^k; spans shorter
/// than a decade fall back to 1-2-5 ticks.
std::vector<Tick> log_ticks(double lo, double hi, int target) {
  const double l0 = std::log10(lo), l1 = std::log10(hi);
  const int k0 = static_cast<int>(std::ceil(l0 - 1e-9)), k1 = static_cast<int>(std::floor(l1 + 1e-9));
  if (k1 - k0 + 1 < 2) {
    auto t = linear_ticks(lo, hi, target);
    t.erase(std::remove_if(t.begin(), t.end(), [](const Tick& x) { return !(x.value > 0); }), t.end());
    return t;
  }
  const int stride = std::max(1, static_cast<int>(std::ceil((k1 - k0 + 1.0) / std::max(target, 2))));
  std::vector<Tick> ticks;
  for (int k = static_cast<int>(std::floor(l0)); k <= k1; ++k) {
    if (k >= k0 && (k - k0) % stride == 0) {
      Tick t;
      t.value = std::pow(10.0, k);
      t.label.base = "10";
      t.label.sup = with_minus_sign(std::to_string(k));
      ticks.push_back(t);
    }
    if (stride == 1) {
      for (int m = 2; m <= 9; ++m) {
        const double v = m * std::pow(10.0, k);
        if (v >= lo * (1 - 1e-9) && v <= hi * (1 + 1e-9)) ticks.push_back({v, {}, false});
      }
    }
  }
  return ticks;
}

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

struct LegendEntry {
  std::string label;
  Color color;
  LineStyle style = LineStyle::solid;
  Marker marker = Marker::none;
  double width = 2, marker_size = 6;
  bool patch = false;
  std::optional<Color> fill, edge;
};

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

void check_grid(const Grid& g, const char* what) {
  if (g.values.size() != g.nx * g.ny) {
    throw InputError(std::string("plot ") + what + ": grid has " + std::to_string(g.values.size()) +
                     " values but nx * ny = " + std::to_string(g.nx * g.ny) + "; give one value per node");
  }
}

}  // namespace

// =============================================================================================

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
  check_grid(g, "contour");
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

// =============================================================================================

struct Axes::Impl {
  std::vector<Item> items;
  std::string title, xlabel, ylabel;
  std::optional<std::array<double, 2>> xlim, ylim;
  bool log_x = false, log_y = false, equal = false, grid = false;
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
      if (it.kind == Kind::field) return true;
    return false;
  }
};

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
  check_grid(grid, "field");
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
  check_grid(grid, "contour");
  if (!label_format.empty() && !one_double_format(label_format)) {
    throw InputError("plot contour: label format \"" + label_format +
                     "\" must hold exactly one %f, %e or %g conversion (write %% for a percent sign)");
  }
  Item it;
  it.kind = Kind::contour;
  it.grid = std::make_shared<const Grid>(grid);
  for (double level : levels) {
    if (!finite(level)) continue;
    it.levels.push_back(level);
    it.contours.push_back(contour_lines(grid, level));
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
Axes& Axes::equal_aspect(bool on) { impl_->equal = on; return *this; }
Axes& Axes::grid_lines(bool on) { impl_->grid = on; return *this; }
Axes& Axes::legend(const std::string& where) {
  static const char* const allowed[] = {"best", "upper right", "upper left", "lower right", "lower left", "none"};
  for (const char* a : allowed) {
    if (where == a) {
      impl_->legend_where = where;
      return *this;
    }
  }
  throw InputError("plot legend: placement \"" + where +
                   "\" is not one of best, upper right, upper left, lower right, lower left, none");
}

// =============================================================================================
// Layout and rendering.

namespace {

struct ColorBar {
  bool on = false;
  double vmin = 0, vmax = 1;
  bool diverging = false;
  std::string label;
  Scale scale;
  std::vector<Tick> ticks;
  Label mult;  // common "×10^k" of the tick labels, if any
  int L = 0, T = 0, R = 0, B = 0;
};

/// Everything a panel needs to be drawn, computed from its cell and its items.
struct PanelLayout {
  int L = 0, T = 0, R = 0, B = 0;  // plot rectangle [L, R) × [T, B) in final pixels
  Scale xs, ys;
  std::vector<Tick> xt, yt;
  Label xmult, ymult;  // common "×10^k" of the tick labels, if any
  ColorBar cbar;
  double ytick_w = 0;
};

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

std::vector<Tick> make_ticks(const Scale& s, int target, Label* multiplier) {
  if (s.log) {
    *multiplier = Label{};
    return log_ticks(s.lo, s.hi, target);
  }
  return linear_ticks(s.lo, s.hi, target, multiplier);
}

/// Picks the densest tick set whose labels do not collide along an axis of `length_px`, with at
/// least two labelled ticks where the range allows.
std::vector<Tick> fit_ticks(Fonts& fonts, const Scale& s, double length_px, bool horizontal, Label* multiplier) {
  auto n_labelled = [](const std::vector<Tick>& ticks) {
    int n = 0;
    for (const auto& t : ticks) n += t.major && !t.label.base.empty();
    return n;
  };
  auto collide = [&](const std::vector<Tick>& ticks) {
    double need = 0;
    for (const auto& t : ticks) {
      if (!t.major || t.label.base.empty()) continue;
      need += horizontal ? label_width(fonts, t.label, kTickPx) + 14 : kTickPx * 1.9;
    }
    return need > std::abs(length_px);
  };
  int target = std::clamp(static_cast<int>(std::abs(length_px) / (horizontal ? 75.0 : 45.0)), 3, 12);
  auto ticks = make_ticks(s, target, multiplier);
  while (n_labelled(ticks) < 2 && target < 12) ticks = make_ticks(s, ++target, multiplier);
  while (collide(ticks) && target > 1) {
    Label m;
    auto fewer = make_ticks(s, --target, &m);
    if (n_labelled(fewer) < 2) break;
    ticks = std::move(fewer);
    *multiplier = m;
  }
  return ticks;
}

/// Colour range of a field: its finite values (symmetric about 0 when diverging), or the
/// caller's vmin/vmax; never zero-size.
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

/// The colour bar shows the last field of the panel (each field keeps its own range).
void resolve_colorbar(const Axes::Impl& a, ColorBar& cb) {
  for (const auto& it : a.items) {
    if (it.kind != Kind::field) continue;
    const auto range = field_range(it);
    cb.on = true;
    cb.vmin = range[0];
    cb.vmax = range[1];
    cb.diverging = it.diverging;
    cb.label = it.label;
  }
}

double max_tick_width(Fonts& fonts, const std::vector<Tick>& ticks) {
  double w = 0;
  for (const auto& t : ticks)
    if (t.major) w = std::max(w, label_width(fonts, t.label, kTickPx));
  return w;
}

/// Places the plot rectangle in the cell so that ticks, labels, title and colour bar fit.
PanelLayout layout_panel(Fonts& fonts, const Axes::Impl& a, int cx0, int cy0, int cx1, int cy1) {
  PanelLayout p;
  resolve_range(a, true, p.xs);
  resolve_range(a, false, p.ys);
  resolve_colorbar(a, p.cbar);
  p.cbar.scale.lo = p.cbar.vmin;
  p.cbar.scale.hi = p.cbar.vmax;
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
    p.xt = fit_ticks(fonts, p.xs, w, true, &p.xmult);
    p.yt = fit_ticks(fonts, p.ys, h, false, &p.ymult);
    p.ytick_w = max_tick_width(fonts, p.yt);
    double right = pad;
    if (!p.xt.empty()) {
      // The last x tick label may stick out to the right of the frame.
      for (const auto& t : p.xt) {
        if (!t.major) continue;
        const double x = L + p.xs.t(t.value) * w;
        right = std::max(right, x + label_width(fonts, t.label, kTickPx) / 2 - R + pad);
      }
    }
    if (p.cbar.on) {
      p.cbar.ticks = linear_ticks(p.cbar.vmin, p.cbar.vmax, std::clamp(static_cast<int>(h / 50), 2, 10), &p.cbar.mult);
      right = 16 + 18 + kTickLen + 4 + max_tick_width(fonts, p.cbar.ticks) +
              (p.cbar.label.empty() ? 0 : 10 + kLabelPx) + pad;
    }
    const double left = pad + (a.ylabel.empty() ? 0 : kLabelPx + 10) + p.ytick_w + 4 + kTickLen;
    // Room for a "×10^k" above the y axis or colour bar, and below the x tick labels.
    const bool mult_above = !p.ymult.base.empty() || (p.cbar.on && !p.cbar.mult.base.empty());
    const double top_now = std::max(top, mult_above ? pad + kTickPx + 8 : 0.0);
    const double bottom_now =
        a.xlabel.empty() && !p.xmult.base.empty() ? bottom + 10 + kTickPx : bottom;
    L = cx0 + left;
    R = cx1 - right;
    T = cy0 + top_now;
    B = cy1 - bottom_now;
    if (R - L < 20) R = L + 20;
    if (B - T < 20) B = T + 20;
  }
  p.L = static_cast<int>(std::lround(L));
  p.R = static_cast<int>(std::lround(R));
  p.T = static_cast<int>(std::lround(T));
  p.B = static_cast<int>(std::lround(B));
  p.xs.p0 = p.L, p.xs.p1 = p.R;
  p.ys.p0 = p.B, p.ys.p1 = p.T;
  if (p.cbar.on) {
    p.cbar.L = p.R + 16;
    p.cbar.R = p.cbar.L + 18;
    p.cbar.T = p.T;
    p.cbar.B = p.B;
    p.cbar.scale.p0 = p.cbar.B;
    p.cbar.scale.p1 = p.cbar.T;
  }
  return p;
}

struct TextJob {
  TextJob(double x_, double y_, std::string s_, double px_, Color c_, double angle_ = 0, double halign_ = 0,
          VAlign valign_ = VAlign::baseline, bool bold_ = false)
      : x(x_), y(y_), s(std::move(s_)), px(px_), c(c_), angle(angle_), halign(halign_), valign(valign_), bold(bold_) {}
  double x, y;
  std::string s;
  double px;
  Color c;
  double angle = 0, halign = 0;
  VAlign valign = VAlign::baseline;
  bool bold = false;
  Label label;  // used when `rich`
  bool rich = false;
};

double pixel_center(double p) { return std::floor(p) + 0.5; }

std::vector<LegendEntry> legend_entries(const Axes::Impl& a) {
  std::vector<LegendEntry> out;
  for (const auto& it : a.items) {
    if (it.label.empty()) continue;
    LegendEntry e;
    e.label = it.label;
    e.color = it.color;
    switch (it.kind) {
      case Kind::line:
        e.style = it.style, e.marker = it.marker, e.width = it.width, e.marker_size = it.size;
        break;
      case Kind::scatter:
        e.style = LineStyle::none, e.marker = it.marker, e.marker_size = it.size;
        break;
      case Kind::contour:
      case Kind::hline:
      case Kind::vline:
        e.style = it.style, e.width = it.width;
        break;
      case Kind::polygon:
        e.patch = true, e.fill = it.fill, e.edge = it.edge;
        break;
      default: continue;
    }
    out.push_back(e);
  }
  return out;
}

class Renderer {
 public:
  Renderer(Fonts& fonts, Raster& raster) : fonts_(fonts), r_(raster) {}
  std::vector<TextJob> texts;

  void draw_panel(const Axes::Impl& a, const PanelLayout& p) {
    const double L = p.L, R = p.R, T = p.T, B = p.B;
    r_.set_clip(L, T, R, B);
    std::vector<P2> data_points;  // for legend placement
    for (const auto& it : a.items)
      if (it.kind == Kind::field) draw_field(it, p);
    if (a.grid) {
      for (const auto& t : p.xt) {
        if (!t.major) continue;
        const double x = pixel_center(p.xs.to_px(t.value));
        r_.stroke_segment({x, T}, {x, B}, 1, kGrid);
      }
      for (const auto& t : p.yt) {
        if (!t.major) continue;
        const double y = pixel_center(p.ys.to_px(t.value));
        r_.stroke_segment({L, y}, {R, y}, 1, kGrid);
      }
    }
    for (const auto& it : a.items) {
      switch (it.kind) {
        case Kind::line: draw_line(it, p, data_points); break;
        case Kind::scatter:
          for (std::size_t i = 0; i < it.x.size(); ++i) {
            const P2 q{p.xs.to_px(it.x[i]), p.ys.to_px(it.y[i])};
            r_.marker(q, it.marker, it.size, it.color);
            data_points.push_back(q);
          }
          break;
        case Kind::error_bars: draw_error_bars(it, p, data_points); break;
        case Kind::contour: draw_contour(it, p, data_points); break;
        case Kind::polygon: draw_polygon(it, p, data_points); break;
        case Kind::hline: {
          const double y = p.ys.to_px(it.y[0]);
          if (finite(y)) {
            r_.stroke_polyline({{L, y}, {R, y}}, it.width, it.color, it.style);
            sample_polyline({{L, y}, {R, y}}, data_points);
          }
          break;
        }
        case Kind::vline: {
          const double x = p.xs.to_px(it.x[0]);
          if (finite(x)) {
            r_.stroke_polyline({{x, T}, {x, B}}, it.width, it.color, it.style);
            sample_polyline({{x, T}, {x, B}}, data_points);
          }
          break;
        }
        case Kind::text: {
          const double x = p.xs.to_px(it.x[0]), y = p.ys.to_px(it.y[0]);
          if (finite(x) && finite(y) && x >= L && x <= R && y >= T && y <= B)
            texts.push_back({x, y, it.label, it.font_px, it.color});
          break;
        }
        case Kind::field: break;
      }
    }
    r_.reset_clip();
    draw_frame_and_ticks(a, p);
    if (p.cbar.on) draw_colorbar(a, p);
    draw_legend(a, p, data_points);
  }

  void draw_suptitle(const std::string& s, double width) {
    texts.push_back({width / 2, 10, s, kSupTitlePx, kBlack, 0, 0.5, VAlign::top, true});
  }

 private:
  void draw_field(const Item& it, const PanelLayout& p) {
    const Grid& g = *it.grid;
    if (g.nx < 2 || g.ny < 2 || !(g.x1 != g.x0) || !(g.y1 != g.y0)) return;
    const auto range = field_range(it);
    const double lo = range[0], hi = range[1];
    const int ss = r_.ss();
    // Colour look-up table (1024 steps) keeps the per-sample cost to a table read.
    static constexpr int kLut = 1024;
    std::vector<Color> lut(kLut);
    for (int k = 0; k < kLut; ++k) {
      const double t = static_cast<double>(k) / (kLut - 1);
      lut[k] = it.diverging ? colormap_diverging(t) : colormap(t);
    }
    const double gx0 = p.xs.to_px(std::min(g.x0, g.x1)), gx1 = p.xs.to_px(std::max(g.x0, g.x1));
    const double gy0 = p.ys.to_px(std::max(g.y0, g.y1)), gy1 = p.ys.to_px(std::min(g.y0, g.y1));
    const double px0 = finite(gx0) ? gx0 : p.L, px1 = finite(gx1) ? gx1 : p.R;
    const double py0 = finite(gy0) ? gy0 : p.T, py1 = finite(gy1) ? gy1 : p.B;
    // Fractional grid index of every sample column / row (the axes are separable).
    // Only samples inside the plot rectangle are ever shaded.
    const int W = (p.R + 1) * ss + 2, H = (p.B + 1) * ss + 2;
    std::vector<double> fi(static_cast<std::size_t>(std::max(W, 0)), kNaN), fj(static_cast<std::size_t>(std::max(H, 0)), kNaN);
    for (int i = std::max(0, p.L * ss - 1); i < W && i <= p.R * ss + 1; ++i) {
      const double x = p.xs.from_px((i + 0.5) / ss);
      fi[i] = (x - g.x0) / (g.x1 - g.x0) * static_cast<double>(g.nx - 1);
    }
    for (int j = std::max(0, p.T * ss - 1); j < H && j <= p.B * ss + 1; ++j) {
      const double y = p.ys.from_px((j + 0.5) / ss);
      fj[j] = (y - g.y0) / (g.y1 - g.y0) * static_cast<double>(g.ny - 1);
    }
    const double inv = 1.0 / (hi - lo);
    const double nxm = static_cast<double>(g.nx - 1), nym = static_cast<double>(g.ny - 1);
    r_.shade(std::max(px0, p.L * 1.0), std::max(py0, p.T * 1.0), std::min(px1, p.R * 1.0), std::min(py1, p.B * 1.0),
             [&](int i, int j, Color& c) {
               const double a = fi[i], b = fj[j];
               if (!(a >= -1e-9 && a <= nxm + 1e-9 && b >= -1e-9 && b <= nym + 1e-9)) return false;
               const std::size_t i0 = std::min(static_cast<std::size_t>(std::max(a, 0.0)), g.nx - 2);
               const std::size_t j0 = std::min(static_cast<std::size_t>(std::max(b, 0.0)), g.ny - 2);
               const double u = std::clamp(a - static_cast<double>(i0), 0.0, 1.0);
               const double v = std::clamp(b - static_cast<double>(j0), 0.0, 1.0);
               const double f00 = g.at(i0, j0), f10 = g.at(i0 + 1, j0), f01 = g.at(i0, j0 + 1),
                            f11 = g.at(i0 + 1, j0 + 1);
               double f;
               if (finite(f00) && finite(f10) && finite(f01) && finite(f11)) {
                 f = (1 - v) * ((1 - u) * f00 + u * f10) + v * ((1 - u) * f01 + u * f11);
               } else {
                 f = g.at(u < 0.5 ? i0 : i0 + 1, v < 0.5 ? j0 : j0 + 1);  // nearest node next to a hole
                 if (!finite(f)) return false;
               }
               const double t = std::clamp((f - lo) * inv, 0.0, 1.0);
               c = lut[static_cast<std::size_t>(t * (kLut - 1) + 0.5)];
               return true;
             });
  }

  std::vector<std::vector<P2>> to_pixels(const std::vector<double>& x, const std::vector<double>& y,
                                         const PanelLayout& p) {
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

  void draw_line(const Item& it, const PanelLayout& p, std::vector<P2>& pts) {
    for (const auto& run : to_pixels(it.x, it.y, p)) {
      if (run.empty()) continue;
      if (run.size() == 1 && it.marker == Marker::none && it.style != LineStyle::none)
        r_.fill_circle(run[0], it.width, it.color);  // a lone point stays visible
      r_.stroke_polyline(run, it.width, it.color, it.style);
      for (const auto& q : run) r_.marker(q, it.marker, it.size, it.color);
      if (it.style == LineStyle::none) pts.insert(pts.end(), run.begin(), run.end());
      else sample_polyline(run, pts);
    }
  }

  // Points every few pixels along a polyline, so that "best" legend placement avoids lines
  // between sparse data points too.
  static void sample_polyline(const std::vector<P2>& run, std::vector<P2>& pts) {
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

  void draw_error_bars(const Item& it, const PanelLayout& p, std::vector<P2>& pts) {
    for (std::size_t i = 0; i < it.x.size(); ++i) {
      const double e = std::abs(it.err[i]);
      const double x = p.xs.to_px(it.x[i]);
      const double y0 = p.ys.to_px(it.y[i] - e), y1 = p.ys.to_px(it.y[i] + e);
      if (!finite(x) || !finite(y1)) continue;
      const double lo = finite(y0) ? y0 : p.B + 10.0;
      r_.stroke_segment({x, lo}, {x, y1}, 1.3, it.color);
      r_.stroke_segment({x - 4, lo}, {x + 4, lo}, 1.3, it.color);
      r_.stroke_segment({x - 4, y1}, {x + 4, y1}, 1.3, it.color);
      pts.push_back({x, lo});
      pts.push_back({x, y1});
    }
  }

  void draw_polygon(const Item& it, const PanelLayout& p, std::vector<P2>& pts) {
    std::vector<P2> q;
    q.reserve(it.vertices.size());
    for (const auto& v : it.vertices) {
      const P2 a{p.xs.to_px(v[0]), p.ys.to_px(v[1])};
      if (!finite(a[0]) || !finite(a[1])) return;
      q.push_back(a);
    }
    if (q.empty()) return;
    if (it.fill) r_.fill_polygon(q, *it.fill);
    if (it.edge && it.width > 0) r_.stroke_polyline(q, it.width, *it.edge, LineStyle::solid, true);
    if (!it.label.empty() || pts.size() < 4096) pts.push_back(q[0]);
  }

  void draw_contour(const Item& it, const PanelLayout& p, std::vector<P2>& pts) {
    std::vector<std::array<double, 4>> placed;  // label boxes already used (centre x, y, half w, half h)
    for (std::size_t l = 0; l < it.levels.size(); ++l) {
      std::string text;
      if (!it.format.empty()) {
        char buf[128];
        std::snprintf(buf, sizeof buf, it.format.c_str(), it.levels[l] * it.scale);
        text = with_minus_sign(buf);
      }
      const double tw = text.empty() ? 0 : fonts_.width(text, kContourPx);
      for (const auto& line : it.contours[l]) {
        std::vector<P2> q;
        for (const auto& v : line) {
          const P2 a{p.xs.to_px(v[0]), p.ys.to_px(v[1])};
          if (finite(a[0]) && finite(a[1])) q.push_back(a);
        }
        if (q.size() < 2) continue;
        for (std::size_t k = 0; k < q.size(); k += 8) pts.push_back(q[k]);
        const auto cum = Raster::cumulative_length(q);
        const double total = cum.back();
        std::vector<std::pair<double, double>> keep{{0, total}};
        if (!text.empty() && total > 2.5 * tw + 20) {
          for (double frac : {0.5, 0.25, 0.75}) {
            const double s = frac * total;
            const P2 c = Raster::point_at(q, cum, s);
            const P2 a = Raster::point_at(q, cum, s - tw / 2), b = Raster::point_at(q, cum, s + tw / 2);
            if (c[0] < p.L + tw / 2 + 2 || c[0] > p.R - tw / 2 - 2 || c[1] < p.T + 8 || c[1] > p.B - 8) continue;
            bool clash = false;
            for (const auto& o : placed)
              if (std::abs(o[0] - c[0]) < o[2] + tw / 2 + 4 && std::abs(o[1] - c[1]) < o[3] + kContourPx) clash = true;
            if (clash) continue;
            double angle = std::atan2(-(b[1] - a[1]), b[0] - a[0]) * 180 / kPi;
            if (angle > 90) angle -= 180;
            if (angle < -90) angle += 180;
            texts.push_back({c[0], c[1], text, kContourPx, it.color, angle, 0.5, VAlign::center});
            placed.push_back({c[0], c[1], tw / 2, kContourPx / 2});
            keep = {{0, s - tw / 2 - 4}, {s + tw / 2 + 4, total}};
            break;
          }
        }
        const bool closed = std::hypot(q.front()[0] - q.back()[0], q.front()[1] - q.back()[1]) < 1e-6;
        if (keep.size() == 1) {
          r_.stroke_polyline(q, it.width, it.color, it.style, false);
          if (closed && it.width >= 1.4) r_.fill_circle(q.front(), it.width / 2, it.color);
        } else {
          for (const auto& run : Raster::cut_polyline(q, cum, keep)) r_.stroke_polyline(run, it.width, it.color, it.style);
        }
      }
    }
  }

  void draw_frame_and_ticks(const Axes::Impl& a, const PanelLayout& p) {
    const double L = p.L, R = p.R, T = p.T, B = p.B;
    // Frame: one-pixel lines just outside the plot rectangle.
    r_.fill_rect(L - 1, T - 1, R + 1, T, kFrame);
    r_.fill_rect(L - 1, B, R + 1, B + 1, kFrame);
    r_.fill_rect(L - 1, T - 1, L, B + 1, kFrame);
    r_.fill_rect(R, T - 1, R + 1, B + 1, kFrame);
    for (const auto& t : p.xt) {
      const double x = pixel_center(p.xs.to_px(t.value));
      if (!finite(x) || x < L - 1 || x > R + 1) continue;
      const double len = t.major ? kTickLen : kTickLen * 0.6;
      r_.stroke_segment({x, B + 1}, {x, B + 1 + len}, 1, kFrame);
      if (t.major && !t.label.base.empty()) {
        TextJob j{x, B + kTickLen + 5, "", kTickPx, kBlack, 0, 0.5, VAlign::top};
        j.rich = true, j.label = t.label;
        texts.push_back(j);
      }
    }
    for (const auto& t : p.yt) {
      const double y = pixel_center(p.ys.to_px(t.value));
      if (!finite(y) || y < T - 1 || y > B + 1) continue;
      const double len = t.major ? kTickLen : kTickLen * 0.6;
      r_.stroke_segment({L - 1 - len, y}, {L - 1, y}, 1, kFrame);
      if (t.major && !t.label.base.empty()) {
        TextJob j{L - kTickLen - 5, y, "", kTickPx, kBlack, 0, 1, VAlign::center};
        j.rich = true, j.label = t.label;
        texts.push_back(j);
      }
    }
    if (!a.xlabel.empty())
      texts.push_back({(L + R) / 2, B + kTickLen + 5 + kTickPx + 9, a.xlabel, kLabelPx, kBlack, 0, 0.5, VAlign::top});
    if (!p.xmult.base.empty()) rich_text(R, B + kTickLen + 5 + kTickPx + 9, p.xmult, 1, VAlign::top);
    if (!p.ymult.base.empty()) rich_text(L, T - 6, p.ymult, 0, VAlign::bottom);
    if (!a.ylabel.empty()) {
      const double x = L - kTickLen - 5 - p.ytick_w - 9;
      texts.push_back({x, (T + B) / 2, a.ylabel, kLabelPx, kBlack, 90, 0.5, VAlign::bottom});
    }
    if (!a.title.empty()) texts.push_back({(L + R) / 2, T - 9, a.title, kTitlePx, kBlack, 0, 0.5, VAlign::bottom});
  }

  void rich_text(double x, double y, const Label& l, double halign, VAlign valign) {
    TextJob j{x, y, "", kTickPx, kBlack, 0, halign, valign};
    j.rich = true, j.label = l;
    texts.push_back(j);
  }

  void draw_colorbar(const Axes::Impl& a, const PanelLayout& p) {
    const ColorBar& cb = p.cbar;
    const int ss = r_.ss();
    const double top = cb.T, bottom = cb.B;
    r_.shade(cb.L, cb.T, cb.R, cb.B, [&](int, int j, Color& c) {
      const double y = (j + 0.5) / ss;
      const double t = std::clamp((bottom - y) / (bottom - top), 0.0, 1.0);
      c = cb.diverging ? colormap_diverging(t) : colormap(t);
      return true;
    });
    // Contour levels of the panel, marked across the bar in their colour.
    for (const auto& it : a.items) {
      if (it.kind != Kind::contour) continue;
      for (double level : it.levels) {
        const double y = cb.scale.to_px(level);
        if (finite(y) && y >= cb.T && y <= cb.B) r_.stroke_segment({cb.L * 1.0, y}, {cb.R * 1.0, y}, 1.2, it.color);
      }
    }
    r_.fill_rect(cb.L - 1, cb.T - 1, cb.R + 1, cb.T, kFrame);
    r_.fill_rect(cb.L - 1, cb.B, cb.R + 1, cb.B + 1, kFrame);
    r_.fill_rect(cb.L - 1, cb.T - 1, cb.L, cb.B + 1, kFrame);
    r_.fill_rect(cb.R, cb.T - 1, cb.R + 1, cb.B + 1, kFrame);
    double w = 0;
    for (const auto& t : cb.ticks) {
      const double y = pixel_center(cb.scale.to_px(t.value));
      if (!finite(y) || y < cb.T - 1 || y > cb.B + 1) continue;
      r_.stroke_segment({cb.R + 1.0, y}, {cb.R + 1 + kTickLen, y}, 1, kFrame);
      TextJob j{cb.R + kTickLen + 5, y, "", kTickPx, kBlack, 0, 0, VAlign::center};
      j.rich = true, j.label = t.label;
      texts.push_back(j);
      w = std::max(w, label_width(fonts_, t.label, kTickPx));
    }
    if (!cb.mult.base.empty()) rich_text(cb.L, cb.T - 6, cb.mult, 0, VAlign::bottom);
    if (!cb.label.empty())
      texts.push_back({cb.R + kTickLen + 5 + w + 9, (top + bottom) / 2, cb.label, kLabelPx, kBlack, 90, 0.5,
                       VAlign::top});
  }

  void draw_legend(const Axes::Impl& a, const PanelLayout& p, const std::vector<P2>& data_points) {
    if (a.legend_where == "none") return;
    const auto entries = legend_entries(a);
    if (entries.empty()) return;
    const double row = kLegendPx * 1.5, handle = 28, pad = 7, gap = 7;
    double tw = 0;
    for (const auto& e : entries) tw = std::max(tw, fonts_.width(e.label, kLegendPx));
    const double bw = pad + handle + gap + tw + pad, bh = pad + row * static_cast<double>(entries.size()) + pad - 4;
    const double inset = 8;
    // "best" tries the corners first (ties keep this order), then the edge centres.
    const char* const order[] = {"upper right", "upper left",  "lower left",   "lower right",
                                 "center right", "center left", "upper center", "lower center"};
    std::string where = a.legend_where;
    auto box_at = [&](const std::string& w) {
      const bool left = w.find("left") != std::string::npos, right = w.find("right") != std::string::npos;
      const bool upper = w.find("upper") != std::string::npos, lower = w.find("lower") != std::string::npos;
      const double x0 = left ? p.L + inset : right ? p.R - inset - bw : (p.L + p.R - bw) / 2;
      const double y0 = upper ? p.T + inset : lower ? p.B - inset - bh : (p.T + p.B - bh) / 2;
      return std::array<double, 2>{x0, y0};
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
    const double x0 = std::round(b[0]), y0 = std::round(b[1]);
    r_.fill_rect(x0, y0, x0 + bw, y0 + bh, Color{200, 200, 200});
    r_.fill_rect(x0 + 1, y0 + 1, x0 + bw - 1, y0 + bh - 1, kWhite);
    for (std::size_t k = 0; k < entries.size(); ++k) {
      const auto& e = entries[k];
      const double cy = y0 + pad + row * (static_cast<double>(k) + 0.5) - 2;
      const double hx0 = x0 + pad, hx1 = hx0 + handle;
      if (e.patch) {
        if (e.fill) r_.fill_rect(hx0 + 4, cy - 6, hx1 - 4, cy + 6, *e.fill);
        if (e.edge) r_.stroke_polyline({{hx0 + 4, cy - 6}, {hx1 - 4, cy - 6}, {hx1 - 4, cy + 6}, {hx0 + 4, cy + 6}},
                                       1, *e.edge, LineStyle::solid, true);
      } else {
        r_.stroke_polyline({{hx0, cy}, {hx1, cy}}, e.width, e.color, e.style);
        r_.marker({(hx0 + hx1) / 2, cy}, e.marker, e.marker_size, e.color);
      }
      texts.push_back({hx1 + gap, cy, e.label, kLegendPx, kBlack, 0, 0, VAlign::center});
    }
  }

  Fonts& fonts_;
  Raster& r_;
};

}  // namespace

struct Figure::Impl {
  int width = 1000, height = 700, rows = 1, cols = 1;
  std::vector<std::unique_ptr<Axes::Impl>> panels;
  std::vector<Axes> handles;
  std::string suptitle;

  std::array<int, 4> cell(int k) const {
    const int r = k / cols, c = k % cols;
    const int top = suptitle.empty() ? 0 : static_cast<int>(kSupTitlePx + 16);
    const double cw = static_cast<double>(width) / cols, ch = static_cast<double>(height - top) / rows;
    return {static_cast<int>(std::lround(c * cw)), static_cast<int>(std::lround(top + r * ch)),
            static_cast<int>(std::lround((c + 1) * cw)), static_cast<int>(std::lround(top + (r + 1) * ch))};
  }

  std::vector<PanelLayout> layout(Fonts& fonts) const {
    std::vector<PanelLayout> out;
    for (std::size_t k = 0; k < panels.size(); ++k) {
      const auto c = cell(static_cast<int>(k));
      out.push_back(layout_panel(fonts, *panels[k], c[0], c[1], c[2], c[3]));
    }
    return out;
  }

  Image render() const {
    Fonts fonts;
    const auto layouts = layout(fonts);
    const double area = static_cast<double>(width) * height;
    const int ss = area <= 4e6 ? 3 : area <= 16e6 ? 2 : 1;
    Raster raster(width, height, ss);
    Renderer renderer(fonts, raster);
    for (std::size_t k = 0; k < panels.size(); ++k) renderer.draw_panel(*panels[k], layouts[k]);
    if (!suptitle.empty()) renderer.draw_suptitle(suptitle, width);
    Image img;
    raster.downsample(img);
    for (const auto& t : renderer.texts) {
      if (t.rich) draw_label(fonts, img, t.x, t.y, t.label, t.px, t.c, t.halign, t.valign);
      else fonts.draw(img, t.x, t.y, t.s, t.px, t.c, t.angle, t.halign, t.valign, t.bold);
    }
    return img;
  }
};

Figure::Figure(int width_px, int height_px, int rows, int cols) {
  if (width_px < 50 || height_px < 50 || width_px > 16384 || height_px > 16384) {
    throw InputError("plot figure size " + std::to_string(width_px) + " x " + std::to_string(height_px) +
                     " px must be between 50 and 16384 px on each side");
  }
  if (rows < 1 || cols < 1 || rows > 20 || cols > 20) {
    throw InputError("plot figure layout " + std::to_string(rows) + " x " + std::to_string(cols) +
                     " panels must have 1 to 20 rows and columns");
  }
  impl_ = new Impl;
  impl_->width = width_px;
  impl_->height = height_px;
  impl_->rows = rows;
  impl_->cols = cols;
  for (int k = 0; k < rows * cols; ++k) {
    impl_->panels.push_back(std::make_unique<Axes::Impl>());
    impl_->handles.emplace_back(impl_->panels.back().get());
  }
}

Figure::~Figure() { delete impl_; }

Axes& Figure::axes(int row, int col) {
  if (row < 0 || col < 0 || row >= impl_->rows || col >= impl_->cols) {
    throw InputError("plot figure: panel (" + std::to_string(row) + ", " + std::to_string(col) +
                     ") is outside the " + std::to_string(impl_->rows) + " x " + std::to_string(impl_->cols) +
                     " layout (rows and columns count from 0)");
  }
  return impl_->handles[static_cast<std::size_t>(row * impl_->cols + col)];
}

Figure& Figure::suptitle(const std::string& t) {
  impl_->suptitle = t;
  return *this;
}

std::array<double, 2> Figure::data_to_pixel(int row, int col, double x, double y) const {
  if (row < 0 || col < 0 || row >= impl_->rows || col >= impl_->cols) {
    throw InputError("plot figure: panel (" + std::to_string(row) + ", " + std::to_string(col) +
                     ") is outside the layout");
  }
  Fonts fonts;
  const auto layouts = impl_->layout(fonts);
  const auto& p = layouts[static_cast<std::size_t>(row * impl_->cols + col)];
  return {p.xs.to_px(x), p.ys.to_px(y)};
}

void Figure::save_png(const std::string& path) const {
  const Image img = impl_->render();
  write_path_atomically(path, [&](const std::string& tmp) {
    png_image image;
    std::memset(&image, 0, sizeof image);
    image.version = PNG_IMAGE_VERSION;
    image.width = static_cast<png_uint_32>(img.w);
    image.height = static_cast<png_uint_32>(img.h);
    image.format = PNG_FORMAT_RGB;
    if (!png_image_write_to_file(&image, tmp.c_str(), 0, img.rgb.data(), img.w * 3, nullptr)) {
      const std::string why = image.message;
      png_image_free(&image);
      throw InputError(path + ": cannot write the PNG (" + why + "); choose a writable path");
    }
  });
}

}  // namespace pvdf::plot
