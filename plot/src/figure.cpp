// Figure: panels laid out on a grid, an optional shared colour bar, rendered with Cairo onto an
// image (PNG), SVG or PDF surface chosen by the file extension, and written atomically.
#include "draw.hpp"

#include "pvdf/core/error.hpp"
#include "pvdf/core/io.hpp"

#include <cairo-pdf.h>
#include <cairo-svg.h>

#include <algorithm>
#include <cctype>
#include <fstream>
#include <sstream>

namespace pvdf::plot {

using namespace detail;

namespace {

enum class Format { png, svg, pdf };

constexpr double kPtPerPx = 0.75;  // SVG and PDF: 96 px per inch

Format format_of(const std::string& path) {
  const auto slash = path.find_last_of('/');
  const auto dot = path.find_last_of('.');
  std::string ext;
  if (dot != std::string::npos && (slash == std::string::npos || dot > slash)) ext = path.substr(dot + 1);
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  if (ext == "png") return Format::png;
  if (ext == "svg") return Format::svg;
  if (ext == "pdf") return Format::pdf;
  throw InputError(path + ": figure format \"" + (ext.empty() ? std::string("(no extension)") : "." + ext) +
                   "\" is not supported; end the file name in .png, .svg or .pdf");
}

std::string xml_escape(const std::string& s) {
  std::string out;
  for (char c : s) {
    switch (c) {
      case '&': out += "&amp;"; break;
      case '<': out += "&lt;"; break;
      case '>': out += "&gt;"; break;
      case '"': out += "&quot;"; break;
      default: out += c;
    }
  }
  return out;
}

/// Cairo draws SVG text as glyph outlines. So that the words of a figure can be searched,
/// selected and read by screen readers, a transparent <text> layer is added at the same places
/// (as scanned PDFs carry an invisible text layer), with the figure's title as <title>.
void add_svg_text_layer(const std::string& file, const std::string& title, const std::vector<TextEngine::Drawn>& drawn) {
  std::ifstream in(file, std::ios::binary);
  std::stringstream buffer;
  buffer << in.rdbuf();
  std::string svg = buffer.str();
  in.close();
  const auto open = svg.find("<svg");
  const auto open_end = open == std::string::npos ? open : svg.find('>', open);
  const auto close = svg.rfind("</svg>");
  if (open_end == std::string::npos || close == std::string::npos || close < open_end) {
    throw InputError(file + ": Cairo wrote no <svg> element; cannot add the text layer");
  }
  std::ostringstream layer;
  layer.precision(6);
  layer << "<g id=\"text-layer\" fill=\"black\" fill-opacity=\"0\" stroke=\"none\" font-family=\"DejaVu Sans\">\n";
  for (const auto& t : drawn) {
    layer << "<text x=\"" << t.x << "\" y=\"" << t.y << "\" font-size=\"" << t.size_px * kPtPerPx << "\"";
    if (t.angle_deg != 0) layer << " transform=\"rotate(" << -t.angle_deg << ' ' << t.x << ' ' << t.y << ")\"";
    layer << ">" << xml_escape(t.plain) << "</text>\n";
  }
  layer << "</g>\n";
  svg.insert(close, layer.str());
  if (!title.empty()) svg.insert(open_end + 1, "\n<title>" + xml_escape(title) + "</title>");
  std::ofstream out(file, std::ios::binary | std::ios::trunc);
  out << svg;
  if (!out) throw InputError(file + ": cannot write the SVG text layer; choose a writable path");
}

void check_surface(cairo_surface_t* s, const std::string& path, const char* what) {
  const cairo_status_t st = cairo_surface_status(s);
  if (st != CAIRO_STATUS_SUCCESS) {
    cairo_surface_destroy(s);
    throw InputError(path + ": cannot write the " + what + " (" + cairo_status_to_string(st) + "); choose a writable path");
  }
}

}  // namespace

struct Figure::Impl {
  int width = 1000, height = 700, rows = 1, cols = 1;
  std::vector<std::unique_ptr<Axes::Impl>> panels;
  std::vector<Axes> handles;
  std::string suptitle;
  bool shared_bar = false;

  struct Layout {
    std::vector<PanelLayout> panels;
    ColorBar shared;  // on if the figure has one shared colour bar
  };

  Layout layout(TextEngine& text) const {
    Layout out;
    double reserve = 0;  // room at the right edge for the shared colour bar
    if (shared_bar) {
      for (const auto& p : panels) {
        if (!p->has_field()) continue;
        out.shared = panel_colorbar(*p);
        break;
      }
      if (out.shared.on) reserve = colorbar_width(text, out.shared, 0.8 * height) + 10;
    }
    const double top = suptitle.empty() ? 0 : kSupTitlePx + 16;
    const double cw = (width - reserve) / cols, ch = (height - top) / rows;
    for (std::size_t k = 0; k < panels.size(); ++k) {
      const int r = static_cast<int>(k) / cols, c = static_cast<int>(k) % cols;
      out.panels.push_back(layout_panel(text, *panels[k], std::round(c * cw), std::round(top + r * ch),
                                        std::round((c + 1) * cw), std::round(top + (r + 1) * ch), !out.shared.on));
    }
    // Panels stacked in a column share their plot's left and right edges (the narrowest span),
    // so that equal x values line up from panel to panel; equal-aspect columns keep their own.
    for (int c = 0; c < cols && rows > 1; ++c) {
      double L = -1e300, R = 1e300;
      bool align = true;
      for (int r = 0; r < rows; ++r) {
        const std::size_t k = static_cast<std::size_t>(r * cols + c);
        if (k >= out.panels.size() || panels[k]->equal) align = false;
        else L = std::max(L, out.panels[k].L), R = std::min(R, out.panels[k].R);
      }
      if (!align || !(R - L >= 20)) continue;
      for (int r = 0; r < rows; ++r) {
        PanelLayout& p = out.panels[static_cast<std::size_t>(r * cols + c)];
        p.L = L, p.R = R;
        p.xs.p0 = L, p.xs.p1 = R;
        if (p.cbar.on) p.cbar.L = p.R + kBarGap, p.cbar.R = p.cbar.L + kBarWidth;
      }
    }
    if (out.shared.on) {
      double T = height, B = 0, R = 0;
      for (const auto& p : out.panels) T = std::min(T, p.T), B = std::max(B, p.B), R = std::max(R, p.R);
      ColorBar& cb = out.shared;
      // Beside the rightmost plot (equal-aspect panels may have shrunk away from the edge).
      cb.L = std::round(std::min(width - reserve + kBarGap, R + kBarGap + 10));
      cb.R = cb.L + kBarWidth;
      cb.T = T, cb.B = B;
      colorbar_width(text, cb, B - T);
    }
    return out;
  }

  void render(cairo_t* cr, TextEngine& text) const {
    set_font_options(cr);
    cairo_set_source_rgb(cr, 1, 1, 1);
    cairo_paint(cr);
    const Layout l = layout(text);
    PanelPainter painter(cr, text);
    for (std::size_t k = 0; k < panels.size(); ++k) painter.draw_panel(*panels[k], l.panels[k]);
    if (l.shared.on) painter.draw_colorbar(l.shared);
    if (!suptitle.empty()) text.draw(width / 2.0, 10, suptitle, kSupTitlePx, Color{0, 0, 0}, 0, 0.5, VAlign::top, true);
  }

  std::string document_title() const {
    if (!suptitle.empty()) return parse_title(suptitle);
    for (const auto& p : panels)
      if (!p->title.empty()) return parse_title(p->title);
    return "";
  }

  static std::string parse_title(const std::string& markup) {
    std::string plain;
    for (const auto& r : parse_markup(markup, 10)) plain += r.utf8;
    return plain;
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

Figure& Figure::shared_colorbar(bool on) {
  impl_->shared_bar = on;
  return *this;
}

std::array<double, 2> Figure::data_to_pixel(int row, int col, double x, double y) const {
  if (row < 0 || col < 0 || row >= impl_->rows || col >= impl_->cols) {
    throw InputError("plot figure: panel (" + std::to_string(row) + ", " + std::to_string(col) +
                     ") is outside the layout");
  }
  MeasureContext m;
  TextEngine text(m.cr);
  const auto l = impl_->layout(text);
  const auto& p = l.panels[static_cast<std::size_t>(row * impl_->cols + col)];
  return {p.xs.to_px(x), p.ys.to_px(y)};
}

std::vector<std::string> Figure::texts() const {
  cairo_surface_t* s = cairo_recording_surface_create(CAIRO_CONTENT_COLOR, nullptr);
  cairo_t* cr = cairo_create(s);
  TextEngine text(cr);
  impl_->render(cr, text);
  cairo_destroy(cr);
  cairo_surface_destroy(s);
  std::vector<std::string> out;
  for (const auto& d : text.drawn) out.push_back(d.plain);
  return out;
}

void Figure::save(const std::string& path) const {
  const Format format = format_of(path);
  const double w = impl_->width, h = impl_->height;
  write_path_atomically(path, [&](const std::string& tmp) {
    cairo_surface_t* s = format == Format::png ? cairo_image_surface_create(CAIRO_FORMAT_RGB24, impl_->width, impl_->height)
                         : format == Format::svg ? cairo_svg_surface_create(tmp.c_str(), w * kPtPerPx, h * kPtPerPx)
                                                 : cairo_pdf_surface_create(tmp.c_str(), w * kPtPerPx, h * kPtPerPx);
    check_surface(s, path, "figure");
    const std::string title = impl_->document_title();
    if (format == Format::pdf) {
      cairo_pdf_surface_set_metadata(s, CAIRO_PDF_METADATA_TITLE, title.c_str());
      cairo_pdf_surface_set_metadata(s, CAIRO_PDF_METADATA_CREATOR, "pvdfkit");
    }
    if (format == Format::svg) cairo_svg_surface_restrict_to_version(s, CAIRO_SVG_VERSION_1_1);
    cairo_t* cr = cairo_create(s);
    if (format != Format::png) cairo_scale(cr, kPtPerPx, kPtPerPx);
    TextEngine text(cr);
    impl_->render(cr, text);
    const cairo_status_t drawn = cairo_status(cr);
    cairo_destroy(cr);
    if (format == Format::png && drawn == CAIRO_STATUS_SUCCESS) {
      const cairo_status_t st = cairo_surface_write_to_png(s, tmp.c_str());
      if (st != CAIRO_STATUS_SUCCESS) {
        cairo_surface_destroy(s);
        throw InputError(path + ": cannot write the PNG (" + std::string(cairo_status_to_string(st)) +
                         "); choose a writable path");
      }
    }
    cairo_surface_finish(s);
    const cairo_status_t st = drawn != CAIRO_STATUS_SUCCESS ? drawn : cairo_surface_status(s);
    cairo_surface_destroy(s);
    if (st != CAIRO_STATUS_SUCCESS) {
      throw InputError(path + ": cannot write the figure (" + std::string(cairo_status_to_string(st)) +
                       "); choose a writable path");
    }
    if (format == Format::svg) add_svg_text_layer(tmp, title, text.drawn);
  });
}

}  // namespace pvdf::plot
