// The one plotting canvas of the examples and benches, drawn straight into an
// image tensor (no plotting library): pixels, lines, discs and text in a 3 x 5
// pixel font, and a log-log frame with a grid line and label at every power of
// ten on both axes. Used by the fit example's loss curve, ssr_tradeoff and
// time_error; write the image with raster::write_png. Built as gradraster_plot
// (examples/common/plot_library.cmake); not part of the installed library.
#pragma once

#include <string>

#include "autodiff/base/tensor.h"

namespace gr::plot {

struct Rgb {
  float r, g, b;
};

// A white [height, width, 3] float32 image to draw on; drawing outside is clipped.
class Canvas {
 public:
  Canvas(int width, int height);
  int width() const { return w_; }
  int height() const { return h_; }
  void put(int x, int y, Rgb c);
  void rect(int x0, int y0, int x1, int y1, Rgb c);  // filled, corners inclusive
  void hline(int x0, int x1, int y, Rgb c) { rect(x0, y, x1, y, c); }
  void vline(int x, int y0, int y1, Rgb c) { rect(x, y0, x, y1, c); }
  void disc(int cx, int cy, int r, Rgb c);
  void ring(int cx, int cy, int r, Rgb c);  // a disc's outline, 2 px thick
  // A straight line `thickness` px wide (a square brush stepped along the longer axis).
  void line(double x0, double y0, double x1, double y1, Rgb c, int thickness = 1);
  // Text in the 3 x 5 font scaled by 2 (8 px per character, 10 px tall), top-left
  // at (x, y). Glyphs: digits, lower-case letters, '.', '-', '+', ':', '/', ' ';
  // any other character is drawn as a space.
  void text(int x, int y, const std::string& s, Rgb c);
  static int text_width(const std::string& s) { return 8 * static_cast<int>(s.size()); }
  const Tensor& image() const { return img_; }

 private:
  Tensor img_;
  int w_, h_;
};

// Plot area margins inside the canvas, in pixels.
struct PlotFrame {
  int width = 720, height = 480;
  int left = 80, right = 30, top = 30, bottom = 60;
};

// A log-log plot whose axes span whole decades: x from 10^floor(log10 x_lo) to
// 10^ceil(log10 x_hi), y likewise (at least one decade each). The constructor
// draws, in this order, the vertical grid lines with their labels below the
// axis, the horizontal ones with labels left of it, the two axis lines, the x
// title under the axis ending at the canvas centre, and the y title top left. Data go on top via
// x()/y() (canvas pixel coordinates of a value) and canvas().
class LogLogPlot {
 public:
  LogLogPlot(double x_lo, double x_hi, double y_lo, double y_hi, const std::string& x_title,
             const std::string& y_title, const PlotFrame& frame = {});
  double x(double value) const;
  double y(double value) const;
  const PlotFrame& frame() const { return f_; }
  Canvas& canvas() { return c_; }
  const Tensor& image() const { return c_.image(); }

 private:
  PlotFrame f_;
  Canvas c_;
  double lx0_, lx1_, ly0_, ly1_;  // decade exponents at the axis ends
};

// A decade's axis label: "%.0f" for values >= 1, else "%.2g" (100, 1, 0.01, 0.0001, 1e-05).
std::string decade_label(double value);

}  // namespace gr::plot
