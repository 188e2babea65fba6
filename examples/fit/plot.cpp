// plot_loss_curve: a small canvas with pixel-level drawing (lines, a 3x5
// bitmap font for the tick labels) over a float32 image tensor.
#include "examples/fit/plot.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <string>

namespace fit {

using gr::Tensor;

namespace {

struct Colour {
  float r, g, b;
};
constexpr Colour kBlack{0, 0, 0}, kGrid{0.85f, 0.85f, 0.85f}, kCurve{0.12f, 0.35f, 0.75f};

// 3x5 glyphs for the characters of tick labels; each row's 3 bits, top row first.
int glyph_row(char c, int row) {
  static const char* chars = "0123456789e-.";
  static const int rows[][5] = {{7, 5, 5, 5, 7}, {2, 6, 2, 2, 7}, {7, 1, 7, 4, 7}, {7, 1, 7, 1, 7},
                                {5, 5, 7, 1, 1}, {7, 4, 7, 1, 7}, {7, 4, 7, 5, 7}, {7, 1, 1, 1, 1},
                                {7, 5, 7, 5, 7}, {7, 5, 7, 1, 7}, {7, 5, 7, 4, 7}, {0, 0, 7, 0, 0},
                                {0, 0, 0, 0, 2}};
  const char* at = std::strchr(chars, c);
  return at && c ? rows[at - chars][row] : 0;
}

class Canvas {
 public:
  Canvas(int width, int height) : image_(Tensor::ones({height, width, 3})), w_(width), h_(height) {}

  void dot(int x, int y, Colour c) {
    if (x < 0 || y < 0 || x >= w_ || y >= h_) return;
    float* p = image_.data<float>() + 3 * (std::int64_t(y) * w_ + x);
    p[0] = c.r, p[1] = c.g, p[2] = c.b;
  }
  // A line `thickness` pixels wide, stepped in quarter pixels.
  void line(double x0, double y0, double x1, double y1, Colour c, int thickness = 1) {
    const int steps = 1 + int(4 * std::max(std::abs(x1 - x0), std::abs(y1 - y0)));
    for (int s = 0; s <= steps; ++s) {
      const double t = double(s) / steps;
      const int x = int(std::lround(x0 + t * (x1 - x0))), y = int(std::lround(y0 + t * (y1 - y0)));
      for (int dy = 0; dy < thickness; ++dy)
        for (int dx = 0; dx < thickness; ++dx) dot(x + dx - thickness / 2, y + dy - thickness / 2, c);
    }
  }
  // Text with its top-left corner at (x, y), glyphs scaled by 2 (6x10 px + 2 px spacing).
  void text(int x, int y, const std::string& s, Colour c) {
    for (char ch : s) {
      for (int row = 0; row < 5; ++row)
        for (int col = 0; col < 3; ++col)
          if (glyph_row(ch, row) & (4 >> col))
            for (int k = 0; k < 4; ++k) dot(x + 2 * col + k % 2, y + 2 * row + k / 2, c);
      x += 8;
    }
  }
  static int text_width(const std::string& s) { return 8 * int(s.size()) - 2; }
  Tensor image() const { return image_; }

 private:
  Tensor image_;
  int w_, h_;
};

}  // namespace

Tensor plot_loss_curve(const std::vector<double>& losses, int width, int height) {
  Canvas canvas(width, height);
  const int left = 60, right = width - 20, top = 20, bottom = height - 36;

  // Log-scale range: whole decades around the finite positive losses.
  double lo = HUGE_VAL, hi = -HUGE_VAL;
  for (double l : losses)
    if (l > 0 && std::isfinite(l)) lo = std::min(lo, l), hi = std::max(hi, l);
  if (!(lo <= hi)) lo = 0.1, hi = 1;
  const int decade_lo = int(std::floor(std::log10(lo))), decade_hi = std::max(decade_lo + 1, int(std::ceil(std::log10(hi))));
  const double last = std::max<double>(1, double(losses.size()) - 1);
  auto px = [&](double i) { return left + (right - left) * i / last; };
  auto py = [&](double l) { return bottom - (bottom - top) * (std::log10(l) - decade_lo) / (decade_hi - decade_lo); };

  // Grid and labels: a horizontal line per decade, five iteration ticks.
  for (int d = decade_lo; d <= decade_hi; ++d) {
    const double y = py(std::pow(10.0, d));
    canvas.line(left, y, right, y, kGrid);
    const std::string label = "1e" + std::to_string(d);
    canvas.text(left - 8 - Canvas::text_width(label), int(y) - 5, label, kBlack);
  }
  for (int k = 0; k <= 4; ++k) {
    const double i = last * k / 4;
    canvas.line(px(i), bottom, px(i), bottom + 5, kBlack);
    const std::string label = std::to_string(int(std::lround(i)));
    canvas.text(int(px(i)) - Canvas::text_width(label) / 2, bottom + 10, label, kBlack);
  }
  canvas.line(left, top, left, bottom, kBlack);
  canvas.line(left, bottom, right, bottom, kBlack);

  // The curve.
  bool have_previous = false;
  double x_prev = 0, y_prev = 0;
  for (std::size_t i = 0; i < losses.size(); ++i) {
    if (!(losses[i] > 0 && std::isfinite(losses[i]))) {
      have_previous = false;
      continue;
    }
    const double x = px(double(i)), y = py(losses[i]);
    if (have_previous) canvas.line(x_prev, y_prev, x, y, kCurve, 2);
    else canvas.dot(int(x), int(y), kCurve);
    x_prev = x, y_prev = y, have_previous = true;
  }
  return canvas.image();
}

}  // namespace fit
