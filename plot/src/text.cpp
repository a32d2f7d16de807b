// Text of figures: a small math markup (sub/superscripts, Greek letters) turned into runs of one
// size and baseline, measured and drawn with Cairo's text API. The face is asked for by name
// ("DejaVu Sans"); fontconfig finds it, so no font file path appears here.
#include "detail.hpp"

#include <map>

namespace pvdf::plot::detail {
namespace {

constexpr double kScriptScale = 0.72;  // size of a sub/superscript relative to its base
constexpr double kSupRise = 0.40;      // superscript baseline above the base baseline, × base size
constexpr double kSubDrop = 0.20;      // subscript baseline below it, × base size

const std::map<std::string, std::string>& symbol_table() {
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
      {"nabla", "\u2207"},   {"$", "$"},            {"\\", "\\"},         {"_", "_"},
      {"^", "^"},            {"%", "%"},            {"{", "{"},           {"}", "}"},
      {",", "\u2009"},       {";", " "},            {"!", ""},            {" ", " "}};
  return table;
}

/// Length of the UTF-8 character starting at s[i] (1 for a stray continuation byte).
std::size_t utf8_length(const std::string& s, std::size_t i) {
  const auto c = static_cast<unsigned char>(s[i]);
  const std::size_t n = c < 0x80 ? 1 : (c >> 5) == 0x6 ? 2 : (c >> 4) == 0xE ? 3 : (c >> 3) == 0x1E ? 4 : 1;
  return std::min(n, s.size() - i);
}

/// Recursive-descent reader of the math part (between dollars) of a label.
class MathReader {
 public:
  MathReader(const std::string& s, std::vector<TextRun>& out) : s_(s), out_(out) {}

  /// Reads until `end` (exclusive) or an unmatched '}' when `in_group`; returns where it stopped.
  std::size_t read(std::size_t i, std::size_t end, double size, double dy, bool in_group) {
    while (i < end) {
      const char c = s_[i];
      if (c == '}' && in_group) return i + 1;
      if (c == '{') {
        i = read(i + 1, end, size, dy, true);
      } else if (c == '_' || c == '^') {
        const double script = size * kScriptScale;
        const double sdy = dy + (c == '^' ? -kSupRise * size : kSubDrop * size);
        i = read_argument(i + 1, end, script, sdy);
      } else if (c == '\\') {
        i = read_command(i, end, size, dy);
      } else {
        const std::size_t n = utf8_length(s_, i);
        emit(s_.substr(i, n), size, dy);
        i += n;
      }
    }
    return i;
  }

 private:
  /// The argument of _ or ^: a {group}, a \command or one character.
  std::size_t read_argument(std::size_t i, std::size_t end, double size, double dy) {
    if (i >= end) return i;
    if (s_[i] == '{') return read(i + 1, end, size, dy, true);
    if (s_[i] == '\\') return read_command(i, end, size, dy);
    const std::size_t n = utf8_length(s_, i);
    emit(s_.substr(i, n), size, dy);
    return i + n;
  }

  std::size_t read_command(std::size_t i, std::size_t end, double size, double dy) {
    std::size_t k = i + 1;
    while (k < end && std::isalpha(static_cast<unsigned char>(s_[k]))) ++k;
    if (k == i + 1 && k < end) ++k;  // one-character commands: \$ \, \_ ...
    const std::string name = s_.substr(i + 1, k - i - 1);
    const auto& table = symbol_table();
    const auto it = table.find(name);
    emit(it != table.end() ? it->second : s_.substr(i, k - i), size, dy);
    return k;
  }

  void emit(const std::string& text, double size, double dy) {
    if (text.empty()) return;
    if (!out_.empty() && out_.back().size_px == size && out_.back().dy == dy) {
      out_.back().utf8 += text;
    } else {
      out_.push_back({text, size, 0, dy});
    }
  }

  const std::string& s_;
  std::vector<TextRun>& out_;
};

/// Valid UTF-8 (Cairo refuses anything else): each invalid byte becomes U+FFFD.
std::string sanitize_utf8(const std::string& s) {
  std::string out;
  for (std::size_t i = 0; i < s.size();) {
    const auto c = static_cast<unsigned char>(s[i]);
    std::size_t n = c < 0x80 ? 1 : (c >> 5) == 0x6 ? 2 : (c >> 4) == 0xE ? 3 : (c >> 3) == 0x1E ? 4 : 0;
    bool ok = n > 0 && i + n <= s.size() && !(n > 1 && c < 0xC2) && !(c > 0xF4);
    for (std::size_t k = 1; ok && k < n; ++k) ok = (static_cast<unsigned char>(s[i + k]) & 0xC0) == 0x80;
    if (ok && n == 1 && c == 0) ok = false;
    if (ok) {
      out.append(s, i, n);
      i += n;
    } else {
      out += "\xEF\xBF\xBD";
      ++i;
    }
  }
  return out;
}

void select_font(cairo_t* cr, bool bold, double size_px) {
  cairo_select_font_face(cr, "DejaVu Sans", CAIRO_FONT_SLANT_NORMAL,
                         bold ? CAIRO_FONT_WEIGHT_BOLD : CAIRO_FONT_WEIGHT_NORMAL);
  cairo_set_font_size(cr, size_px);
}

}  // namespace

std::vector<TextRun> parse_markup(const std::string& raw, double size_px) {
  const std::string markup = sanitize_utf8(raw);
  std::vector<TextRun> runs;
  MathReader reader(markup, runs);
  std::string plain;
  auto flush = [&] {
    if (plain.empty()) return;
    if (!runs.empty() && runs.back().size_px == size_px && runs.back().dy == 0) runs.back().utf8 += plain;
    else runs.push_back({plain, size_px, 0, 0});
    plain.clear();
  };
  for (std::size_t i = 0; i < markup.size();) {
    if (markup[i] == '\\' && i + 1 < markup.size() && markup[i + 1] == '$') {
      plain += '$';
      i += 2;
      continue;
    }
    if (markup[i] == '$') {
      // Math up to the next unescaped dollar; an unpaired dollar is literal.
      std::size_t close = i + 1;
      while (close < markup.size() && !(markup[close] == '$' && markup[close - 1] != '\\')) ++close;
      if (close < markup.size()) {
        flush();
        reader.read(i + 1, close, size_px, 0, false);
        i = close + 1;
        continue;
      }
    }
    plain += markup[i++];
  }
  flush();
  return runs;
}

void set_font_options(cairo_t* cr) {
  cairo_font_options_t* options = cairo_font_options_create();
  cairo_font_options_set_hint_metrics(options, CAIRO_HINT_METRICS_OFF);
  cairo_font_options_set_hint_style(options, CAIRO_HINT_STYLE_SLIGHT);
  cairo_font_options_set_antialias(options, CAIRO_ANTIALIAS_GRAY);
  cairo_set_font_options(cr, options);
  cairo_font_options_destroy(options);
}

MeasureContext::MeasureContext() {
  surface = cairo_image_surface_create(CAIRO_FORMAT_ARGB32, 1, 1);
  cr = cairo_create(surface);
  set_font_options(cr);
}

MeasureContext::~MeasureContext() {
  cairo_destroy(cr);
  cairo_surface_destroy(surface);
}

TextLayout TextEngine::layout(const std::string& markup, double size_px, bool bold) {
  TextLayout out;
  out.runs = parse_markup(markup, size_px);
  cairo_save(cr_);
  double x = 0;
  for (auto& r : out.runs) {
    select_font(cr_, bold, r.size_px);
    cairo_text_extents_t e;
    cairo_text_extents(cr_, r.utf8.c_str(), &e);
    r.dx = x;
    x += e.x_advance;
    out.plain += r.utf8;
  }
  cairo_restore(cr_);
  out.width = x;
  return out;
}

void TextEngine::draw(double x, double y, const std::string& markup, double size_px, Color c, double angle_deg,
                      double halign, VAlign valign, bool bold) {
  const TextLayout t = layout(markup, size_px, bold);
  if (t.runs.empty()) return;
  // Baseline offset for the vertical alignment, from DejaVu Sans' cap height (0.73 em) and
  // descender (0.24 em), so that labels of one size line up whatever their letters.
  const double shift = valign == VAlign::top      ? 0.76 * size_px
                       : valign == VAlign::center ? 0.37 * size_px
                       : valign == VAlign::bottom ? -0.24 * size_px
                                                  : 0.0;
  cairo_save(cr_);
  cairo_translate(cr_, x, y);
  cairo_rotate(cr_, -angle_deg * kPi / 180);
  cairo_translate(cr_, -halign * t.width, shift);
  cairo_set_source_rgb(cr_, c.r / 255.0, c.g / 255.0, c.b / 255.0);
  for (const auto& r : t.runs) {
    select_font(cr_, bold, r.size_px);
    cairo_move_to(cr_, r.dx, r.dy);
    cairo_show_text(cr_, r.utf8.c_str());
  }
  double ux = 0, uy = 0;
  cairo_user_to_device(cr_, &ux, &uy);
  cairo_restore(cr_);
  drawn.push_back({t.plain, ux, uy, size_px, angle_deg});
}

}  // namespace pvdf::plot::detail
