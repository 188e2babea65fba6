// plot_loss_curve on the shared canvas (examples/common/plot_canvas.h).
#include "examples/fit/plot.h"

#include <algorithm>
#include <cmath>
#include <string>

#include "examples/common/plot_canvas.h"

namespace fit {

using gr::Tensor;
using gr::plot::Canvas;
using gr::plot::Rgb;

namespace {
constexpr Rgb kBlack{0, 0, 0}, kGrid{0.85f, 0.85f, 0.85f}, kCurve{0.12f, 0.35f, 0.75f};
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
    else canvas.put(int(x), int(y), kCurve);
    x_prev = x, y_prev = y, have_previous = true;
  }
  return canvas.image();
}

}  // namespace fit
