// Pareto frontier and its plot, drawn with examples/common/plot_canvas.h.
#include "bench/time_error_plot.h"

#include <algorithm>
#include <numeric>

#include "examples/common/plot_canvas.h"

namespace gr::bench {
using plot::Canvas;
using plot::LogLogPlot;
using plot::PlotFrame;
using plot::Rgb;

namespace {

struct Box {
  int x0, y0, x1, y1;
  bool overlaps(const Box& o) const { return x0 <= o.x1 && o.x0 <= x1 && y0 <= o.y1 && o.y0 <= y1; }
};

bool usable(const FrontierPoint& p) { return p.ms > 0 && p.error > 0; }

// A square outline of half-size r, 2 px thick, centred at (x, y).
void square(Canvas& c, int x, int y, int r, Rgb colour) {
  c.rect(x - r, y - r, x + r, y - r + 1, colour), c.rect(x - r, y + r - 1, x + r, y + r, colour);
  c.rect(x - r, y - r, x - r + 1, y + r, colour), c.rect(x + r - 1, y - r, x + r, y + r, colour);
}

}  // namespace

std::vector<std::size_t> pareto_frontier(const std::vector<FrontierPoint>& points) {
  std::vector<std::size_t> order;
  for (std::size_t i = 0; i < points.size(); ++i)
    if (usable(points[i])) order.push_back(i);
  std::sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) {
    return points[a].ms != points[b].ms ? points[a].ms < points[b].ms : points[a].error < points[b].error;
  });
  // Walking from fast to slow, a point is on the frontier when it beats the
  // best error of every faster point.
  std::vector<std::size_t> frontier;
  for (std::size_t i : order)
    if (frontier.empty() || points[i].error < points[frontier.back()].error) frontier.push_back(i);
  return frontier;
}

Tensor plot_frontier(const std::vector<FrontierPoint>& points, const std::string& y_title) {
  double xlo = 1e300, xhi = 0, ylo = 1e300, yhi = 0;
  for (const FrontierPoint& p : points) {
    if (!usable(p)) continue;
    xlo = std::min(xlo, p.ms), xhi = std::max(xhi, p.ms);
    ylo = std::min(ylo, p.error), yhi = std::max(yhi, p.error);
  }
  if (xhi == 0) xlo = 1, xhi = 10, ylo = 0.1, yhi = 1;  // nothing to show: an empty frame
  LogLogPlot plot(xlo, xhi, ylo, yhi, "ms", y_title);
  Canvas& c = plot.canvas();
  const PlotFrame& f = plot.frame();
  const Rgb orange{0.9f, 0.5f, 0.1f}, blue{0.15f, 0.35f, 0.85f}, black{0, 0, 0}, grey{0.3f, 0.3f, 0.3f};
  constexpr int kRadius = 5;

  const std::vector<std::size_t> frontier = pareto_frontier(points);
  for (std::size_t k = 1; k < frontier.size(); ++k) {
    const FrontierPoint &a = points[frontier[k - 1]], &b = points[frontier[k]];
    c.line(plot.x(a.ms), plot.y(a.error), plot.x(b.ms), plot.y(b.error), black, 2);
  }
  for (std::size_t i : frontier)  // a black ring marks frontier points (visible even when alone)
    c.ring(int(plot.x(points[i].ms)), int(plot.y(points[i].error)), kRadius + 4, black);
  std::vector<Box> taken;
  for (const FrontierPoint& p : points) {
    if (!usable(p)) continue;
    const int x = int(plot.x(p.ms)), y = int(plot.y(p.error));
    const Rgb colour = p.float64 ? blue : orange;
    if (p.visibility)
      square(c, x, y, kRadius + 2, colour);
    else if (p.antialias)
      c.disc(x, y, kRadius, colour);
    else
      c.ring(x, y, kRadius, colour);
    taken.push_back({x - kRadius - 4, y - kRadius - 4, x + kRadius + 4, y + kRadius + 4});
  }
  // Labels: the first free spot of right, left, above, below (else right).
  const Box area{f.left + 1, f.top, f.width - 1, f.height - f.bottom - 1};
  for (const FrontierPoint& p : points) {
    if (!usable(p)) continue;
    const int x = int(plot.x(p.ms)), y = int(plot.y(p.error)), w = Canvas::text_width(p.label);
    const Box spots[] = {{x + 12, y - 5, x + 12 + w, y + 5},
                         {x - 12 - w, y - 5, x - 12, y + 5},
                         {x - w / 2, y - 22, x - w / 2 + w, y - 12},
                         {x - w / 2, y + 12, x - w / 2 + w, y + 22}};
    Box chosen = spots[0];
    for (const Box& s : spots) {
      const bool inside = s.x0 >= area.x0 && s.x1 <= area.x1 && s.y0 >= area.y0 && s.y1 <= area.y1;
      if (inside && std::none_of(taken.begin(), taken.end(), [&](const Box& t) { return t.overlaps(s); })) {
        chosen = s;
        break;
      }
    }
    c.text(chosen.x0, chosen.y0, p.label, grey);
    taken.push_back(chosen);
  }
  // Legend in the top margin: f32 orange, f64 blue, filled = antialias, square =
  // visibility_antialias, ring = none.
  int lx = f.width - f.right - 350;
  const int ly = f.top / 2;
  c.disc(lx, ly, kRadius, orange), c.text(lx + 9, ly - 5, "f32", black), lx += 50;
  c.disc(lx, ly, kRadius, blue), c.text(lx + 9, ly - 5, "f64", black), lx += 50;
  c.disc(lx, ly, kRadius, grey), c.text(lx + 9, ly - 5, "aa", black), lx += 42;
  square(c, lx, ly, kRadius + 2, grey), c.text(lx + 11, ly - 5, "vis", black), lx += 52;
  c.ring(lx, ly, kRadius, grey), c.text(lx + 9, ly - 5, "no aa", black), lx += 66;
  c.line(lx - 6, ly, lx + 10, ly, black, 2), c.text(lx + 15, ly - 5, "pareto", black);
  return plot.image();
}

}  // namespace gr::bench
