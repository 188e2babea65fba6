// Canvas primitives, the 3 x 5 font and the log-log frame of plot_canvas.h.
#include "examples/common/plot_canvas.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

namespace gr::plot {
namespace {

// 3 x 5 glyphs, row-major from the top, '#' = ink.
const char* glyph(char c) {
  switch (c) {
    case '0': return "####.##.##.####";
    case '1': return ".#.##..#..#.###";
    case '2': return "###..#####..###";
    case '3': return "###..####..####";
    case '4': return "#.##.####..#..#";
    case '5': return "####..###..####";
    case '6': return "####..####.####";
    case '7': return "###..#..#..#..#";
    case '8': return "####.#####.####";
    case '9': return "####.####..####";
    case '.': return "............#..";
    case '-': return "......###......";
    case '+': return "....#.###.#....";
    case ':': return "....#.....#....";
    case '/': return "..#..#.#.#..#..";
    case 'a': return "....###.##.#.##";
    case 'b': return "#..#..##.#.###.";
    case 'c': return ".......###...##";
    case 'd': return "..#..#.###.#.##";
    case 'e': return "....#.####..###";
    case 'f': return ".###..##.#..#..";
    case 'g': return ".###.####..###.";
    case 'h': return "#..#..##.#.##.#";
    case 'i': return ".#.....#..#..#.";
    case 'j': return "..#.....##.#.#.";
    case 'k': return "#..#.###.#.##.#";
    case 'l': return "#..#..#..#...##";
    case 'm': return "......######.##";
    case 'n': return "......##.#.##.#";
    case 'o': return ".......#.#.#.#.";
    case 'p': return "...####.####...";
    case 'q': return "....###.#.##..#";
    case 'r': return ".......###..#..";
    case 's': return "....###.#.###..";
    case 't': return ".#.###.#..#...#";
    case 'u': return "......#.##.####";
    case 'v': return "......#.##.#.#.";
    case 'w': return "......#.#######";
    case 'x': return "...#.#.#.#.#...";
    case 'y': return "...#.##.#.#.#..";
    case 'z': return "...###.#.#..###";
    default: return "...............";
  }
}

}  // namespace

Canvas::Canvas(int width, int height) : img_(Tensor::ones({height, width, 3})), w_(width), h_(height) {}

void Canvas::put(int x, int y, Rgb c) {
  if (x < 0 || y < 0 || x >= w_ || y >= h_) return;
  float* p = img_.data<float>() + 3 * (std::int64_t(y) * w_ + x);
  p[0] = c.r, p[1] = c.g, p[2] = c.b;
}

void Canvas::rect(int x0, int y0, int x1, int y1, Rgb c) {
  for (int y = y0; y <= y1; ++y)
    for (int x = x0; x <= x1; ++x) put(x, y, c);
}

void Canvas::disc(int cx, int cy, int r, Rgb c) {
  for (int y = -r; y <= r; ++y)
    for (int x = -r; x <= r; ++x)
      if (x * x + y * y <= r * r) put(cx + x, cy + y, c);
}

void Canvas::ring(int cx, int cy, int r, Rgb c) {
  const int inner = std::max(0, r - 2);
  for (int y = -r; y <= r; ++y)
    for (int x = -r; x <= r; ++x) {
      const int d2 = x * x + y * y;
      if (d2 <= r * r && d2 > inner * inner) put(cx + x, cy + y, c);
    }
}

void Canvas::line(double x0, double y0, double x1, double y1, Rgb c, int thickness) {
  const int steps = std::max(1, int(std::ceil(std::max(std::abs(x1 - x0), std::abs(y1 - y0)))));
  const int lo = -(thickness - 1) / 2, hi = thickness / 2;
  for (int k = 0; k <= steps; ++k) {
    const double f = double(k) / steps;
    const int x = int(std::lround(x0 + f * (x1 - x0))), y = int(std::lround(y0 + f * (y1 - y0)));
    rect(x + lo, y + lo, x + hi, y + hi, c);
  }
}

void Canvas::text(int x, int y, const std::string& s, Rgb c) {
  for (char ch : s) {
    const char* g = glyph(ch);
    for (int row = 0; row < 5; ++row)
      for (int col = 0; col < 3; ++col)
        if (g[row * 3 + col] == '#') rect(x + 2 * col, y + 2 * row, x + 2 * col + 1, y + 2 * row + 1, c);
    x += 8;
  }
}

std::string decade_label(double value) {
  char buf[32];
  std::snprintf(buf, sizeof buf, value >= 1 ? "%.0f" : "%.2g", value);
  return buf;
}

LogLogPlot::LogLogPlot(double x_lo, double x_hi, double y_lo, double y_hi, const std::string& x_title,
                       const std::string& y_title, const PlotFrame& frame)
    : f_(frame), c_(frame.width, frame.height) {
  lx0_ = std::floor(std::log10(x_lo)), lx1_ = std::max(lx0_ + 1, std::ceil(std::log10(x_hi)));
  ly0_ = std::floor(std::log10(y_lo)), ly1_ = std::max(ly0_ + 1, std::ceil(std::log10(y_hi)));
  const int W = f_.width, H = f_.height, L = f_.left, R = f_.right, T = f_.top, B = f_.bottom;
  const Rgb grid{0.87f, 0.87f, 0.87f}, black{0, 0, 0};
  for (double d = lx0_; d <= lx1_ + 1e-9; ++d) {
    const int px = int(x(std::pow(10, d)));
    c_.vline(px, T, H - B, grid);
    c_.text(px - 8, H - B + 10, decade_label(std::pow(10, d)), black);
  }
  for (double d = ly0_; d <= ly1_ + 1e-9; ++d) {
    const int py = int(y(std::pow(10, d)));
    c_.hline(L, W - R, py, grid);
    const std::string s = decade_label(std::pow(10, d));
    c_.text(L - 10 - Canvas::text_width(s), py - 5, s, black);
  }
  c_.vline(L, T, H - B, black);
  c_.hline(L, W - R, H - B, black);
  c_.text(W / 2 - Canvas::text_width(x_title), H - 25, x_title, black);
  c_.text(10, T - 20, y_title, black);
}

// Pixel coordinates: x grows to the right from the left margin, y upwards from the bottom margin.
double LogLogPlot::x(double value) const {
  return f_.left + (std::log10(value) - lx0_) / (lx1_ - lx0_) * (f_.width - f_.left - f_.right);
}

double LogLogPlot::y(double value) const {
  return f_.height - f_.bottom - (std::log10(value) - ly0_) / (ly1_ - ly0_) * (f_.height - f_.top - f_.bottom);
}

}  // namespace gr::plot
