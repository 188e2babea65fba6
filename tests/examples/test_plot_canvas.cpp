// The shared plotting canvas (examples/common/plot_canvas.h) of the fit
// example's loss curve and the bench plots.
#include <catch2/catch.hpp>

#include "examples/common/plot_canvas.h"

using gr::plot::Canvas;
using gr::plot::LogLogPlot;
using gr::plot::Rgb;

namespace {
int inked(const Canvas& c) {
  int n = 0;
  const float* p = c.image().data<float>();
  for (std::int64_t i = 0; i < std::int64_t(c.width()) * c.height(); ++i) n += p[3 * i] < 0.5f;
  return n;
}
}  // namespace

TEST_CASE("plot canvas: a white image that clips drawing outside it", "[examples][plot]") {
  Canvas c(40, 30);
  REQUIRE(c.image().shape() == gr::Shape({30, 40, 3}));
  CHECK(inked(c) == 0);
  c.line(-50, -50, 200, 200, Rgb{0, 0, 0}, 3);
  c.disc(-5, 100, 8, Rgb{0, 0, 0});
  const int diagonal = inked(c);
  CHECK(diagonal > 30);
  CHECK(diagonal < 40 * 30 / 5);  // a band along the diagonal, not a fill
}

TEST_CASE("plot canvas: text in the 3 x 5 font takes 8 px a character", "[examples][plot]") {
  Canvas c(64, 16);
  c.text(0, 0, "1e-5", Rgb{0, 0, 0});
  CHECK(Canvas::text_width("1e-5") == 32);
  CHECK(inked(c) > 4 * 4 * 3);  // every glyph inks at least three 2 x 2 blocks
  Canvas blank(64, 16);
  blank.text(0, 0, "    ", Rgb{0, 0, 0});
  CHECK(inked(blank) == 0);
}

TEST_CASE("plot canvas: a log-log plot spans whole decades between its margins", "[examples][plot]") {
  const LogLogPlot p(2, 50, 0.003, 0.2, "ms", "err");
  const auto& f = p.frame();
  CHECK(p.x(1) == Approx(f.left));
  CHECK(p.x(100) == Approx(f.width - f.right));
  CHECK(p.x(10) == Approx((f.left + f.width - f.right) / 2.0));
  CHECK(p.y(0.001) == Approx(f.height - f.bottom));
  CHECK(p.y(1) == Approx(f.top));
}
