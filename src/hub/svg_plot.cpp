#include "svg_plot.hpp"

#include <algorithm>
#include <cmath>

#include <fmt/format.h>

namespace scaratwin::svg {
namespace {

constexpr int kLeft = 58, kRight = 12, kTop = 28, kBottom = 42;

std::string escape(const std::string& s) {
  std::string o;
  for (char c : s) {
    if (c == '<')
      o += "&lt;";
    else if (c == '>')
      o += "&gt;";
    else if (c == '&')
      o += "&amp;";
    else
      o += c;
  }
  return o;
}

// "Nice" tick step for a range.
double tick_step(double span, int target) {
  if (!(span > 0.0)) return 1.0;
  const double raw = span / target;
  const double mag = std::pow(10.0, std::floor(std::log10(raw)));
  for (double m : {1.0, 2.0, 2.5, 5.0, 10.0}) {
    if (raw <= m * mag) return m * mag;
  }
  return 10.0 * mag;
}

struct Frame {
  double x0, x1, y0, y1;
  int w, h;
  double px(double x) const { return kLeft + (x - x0) / (x1 - x0) * (w - kLeft - kRight); }
  double py(double y) const { return h - kBottom - (y - y0) / (y1 - y0) * (h - kTop - kBottom); }
};

std::string axes(const Frame& f, const std::string& title, const std::string& xl,
                 const std::string& yl) {
  std::string s = fmt::format(
      "<svg xmlns='http://www.w3.org/2000/svg' width='{0}' height='{1}' viewBox='0 0 {0} {1}' "
      "font-family='sans-serif' font-size='11'>\n<rect width='{0}' height='{1}' fill='white'/>\n"
      "<text x='{2}' y='16' font-size='13' font-weight='bold'>{3}</text>\n",
      f.w, f.h, kLeft, escape(title));
  const double xs = tick_step(f.x1 - f.x0, 6), ys = tick_step(f.y1 - f.y0, 5);
  for (double x = std::ceil(f.x0 / xs) * xs; x <= f.x1 + 1e-12; x += xs) {
    s += fmt::format(
        "<line x1='{0:.1f}' y1='{1}' x2='{0:.1f}' y2='{2}' stroke='#e5e5e5'/>"
        "<text x='{0:.1f}' y='{3}' text-anchor='middle'>{4:g}</text>\n",
        f.px(x), kTop, f.h - kBottom, f.h - kBottom + 14, std::abs(x) < xs * 1e-6 ? 0.0 : x);
  }
  for (double y = std::ceil(f.y0 / ys) * ys; y <= f.y1 + 1e-12; y += ys) {
    s += fmt::format(
        "<line x1='{0}' y1='{1:.1f}' x2='{2}' y2='{1:.1f}' stroke='#e5e5e5'/>"
        "<text x='{3}' y='{4:.1f}' text-anchor='end'>{5:g}</text>\n",
        kLeft, f.py(y), f.w - kRight, kLeft - 4, f.py(y) + 4, std::abs(y) < ys * 1e-6 ? 0.0 : y);
  }
  s += fmt::format(
      "<rect x='{0}' y='{1}' width='{2}' height='{3}' fill='none' stroke='#888'/>\n"
      "<text x='{4}' y='{5}' text-anchor='middle'>{6}</text>\n"
      "<text transform='translate(14 {7}) rotate(-90)' text-anchor='middle'>{8}</text>\n",
      kLeft, kTop, f.w - kLeft - kRight, f.h - kTop - kBottom, (kLeft + f.w - kRight) / 2, f.h - 8,
      escape(xl), (kTop + f.h - kBottom) / 2, escape(yl));
  return s;
}

}  // namespace

std::string line_chart(const std::string& title, const std::string& x_label,
                       const std::string& y_label, const std::vector<Series>& series, int width,
                       int height, bool equal_aspect) {
  double x0 = INFINITY, x1 = -INFINITY, y0 = INFINITY, y1 = -INFINITY;
  for (const Series& s : series) {
    for (size_t i = 0; i < s.x.size() && i < s.y.size(); ++i) {
      if (!std::isfinite(s.x[i]) || !std::isfinite(s.y[i])) continue;
      x0 = std::min(x0, s.x[i]);
      x1 = std::max(x1, s.x[i]);
      y0 = std::min(y0, s.y[i]);
      y1 = std::max(y1, s.y[i]);
    }
  }
  if (!std::isfinite(x0)) x0 = 0, x1 = 1, y0 = 0, y1 = 1;
  if (x1 - x0 < 1e-12) x0 -= 0.5, x1 += 0.5;
  if (y1 - y0 < 1e-12) y0 -= 0.5, y1 += 0.5;
  const double pad = 0.05 * (y1 - y0);
  y0 -= pad;
  y1 += pad;
  if (equal_aspect) {
    // same metres per pixel on both axes.
    const double pw = width - kLeft - kRight, ph = height - kTop - kBottom;
    const double scale = std::max((x1 - x0) / pw, (y1 - y0) / ph);
    const double cx = 0.5 * (x0 + x1), cy = 0.5 * (y0 + y1);
    x0 = cx - 0.5 * scale * pw;
    x1 = cx + 0.5 * scale * pw;
    y0 = cy - 0.5 * scale * ph;
    y1 = cy + 0.5 * scale * ph;
  }
  const Frame f{x0, x1, y0, y1, width, height};
  std::string out = axes(f, title, x_label, y_label);
  int legend = 0;
  // the legend sits in the top right corner, as wide as its longest name (about 6.2 px a
  // character at 11 px sans-serif) so that no name runs past the frame
  size_t longest = 0;
  for (const Series& s : series) longest = std::max(longest, s.name.size());
  const int legend_x = width - kRight - 26 - static_cast<int>(6.2 * static_cast<double>(longest));
  for (const Series& s : series) {
    std::string pts;
    // at most ~2000 points per series keep the file small.
    const size_t n = std::min(s.x.size(), s.y.size());
    const size_t stride = std::max<size_t>(1, n / 2000);
    for (size_t i = 0; i < n; i += stride) {
      if (!std::isfinite(s.x[i]) || !std::isfinite(s.y[i])) continue;
      pts += fmt::format("{:.1f},{:.1f} ", f.px(s.x[i]), f.py(s.y[i]));
    }
    out += fmt::format("<polyline fill='none' stroke='{}' stroke-width='1.6'{} points='{}'/>\n",
                       s.color, s.dashed ? " stroke-dasharray='5 3'" : "", pts);
    out += fmt::format(
        "<line x1='{0}' y1='{1}' x2='{2}' y2='{1}' stroke='{3}' stroke-width='2'{5}/>"
        "<text x='{4}' y='{6}'>{7}</text>\n",
        legend_x, kTop + 10 + 14 * legend, legend_x + 18, s.color, legend_x + 22, s.dashed ? " stroke-dasharray='5 3'" : "", kTop + 14 + 14 * legend,
        escape(s.name));
    ++legend;
  }
  return out + "</svg>\n";
}

std::string histogram(const std::string& title, const std::string& x_label,
                      const std::vector<double>& values, int bins, int width, int height) {
  double lo = INFINITY, hi = -INFINITY;
  for (double v : values) {
    lo = std::min(lo, v);
    hi = std::max(hi, v);
  }
  if (!std::isfinite(lo)) lo = 0, hi = 1;
  if (hi - lo < 1e-9) hi = lo + 1e-3;
  std::vector<int> count(static_cast<size_t>(bins), 0);
  for (double v : values) {
    int b = static_cast<int>((v - lo) / (hi - lo) * bins);
    count[static_cast<size_t>(std::clamp(b, 0, bins - 1))]++;
  }
  const int peak = std::max(1, *std::max_element(count.begin(), count.end()));
  const Frame f{lo, hi, 0.0, peak * 1.08, width, height};
  std::string out = axes(f, title, x_label, "frames");
  for (int b = 0; b < bins; ++b) {
    const double xa = lo + (hi - lo) * b / bins, xb = lo + (hi - lo) * (b + 1) / bins;
    out += fmt::format(
        "<rect x='{:.1f}' y='{:.1f}' width='{:.1f}' height='{:.1f}' "
        "fill='#4a7fc1'/>\n",
        f.px(xa), f.py(count[static_cast<size_t>(b)]), std::max(0.5, f.px(xb) - f.px(xa) - 0.5),
        f.py(0.0) - f.py(count[static_cast<size_t>(b)]));
  }
  return out + "</svg>\n";
}

}  // namespace scaratwin::svg
