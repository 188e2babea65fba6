// What lets the fit's views run concurrently (docs/performance.md): the
// surface they share, as leaves each view can alias on its own thread and
// tape, and the order in which a process starts its views.
#pragma once

#include <vector>

#include "autodiff/base/tensor.h"
#include "autodiff/view_gradients.h"
#include "examples/fit/geometry.h"
#include "examples/fit/shading.h"

namespace fit {

// What the views of one step share, as leaves of their own: the render
// vertices' positions, normals and colours (or the texture). update() computes
// them once per step from the smoothed positions, recorded on this thread's
// tape, and copies their values into the leaves. Each view renders from its
// aliases of the leaves (ViewGradients::view_leaves) on a tape of its own;
// once the views' gradients are summed into the leaves, add_pullback() carries
// them on to the positions in one backward.
class SharedSurface {
 public:
  // mesh and material must outlive this object; a material's texture is the
  // fitted leaf itself (the views differentiate it directly).
  SharedSurface(const SurfaceMesh& mesh, const Material& material);

  // The leaves, in the order as_surface() reads them: vertices, normals, colours or texture.
  const std::vector<Tensor>& leaves() const { return leaves_; }
  // Computes the surface from `positions` (recorded) and copies its values into the leaves.
  void update(const Tensor& positions);
  // A view's surface from its aliases of leaves() (the first three of `leaves`).
  Surface as_surface(const std::vector<Tensor>& leaves) const;
  // Adds to a linear form's pairs (gr::sum_of_products) each recorded value
  // with its leaf's gradient: the form's gradient with respect to each value
  // is the leaf's gradient, so its backward carries the views' sum on to the
  // positions (and colours).
  void add_pullback(std::vector<Tensor>& values, std::vector<Tensor>& weights) const;
  // Clears the leaves' gradients (not the texture's: the optimizer owns it).
  void zero_grad();

 private:
  const SurfaceMesh& mesh_;
  const Material& material_;
  std::vector<Tensor> leaves_;
  Surface recorded_;
};

// The order the views of one process start in: the longest of the last step
// first, so that the concurrent views end close together (greedy
// longest-first scheduling). Only when each view runs changes, not what it
// computes: results are the same for any order.
class ViewSchedule {
 public:
  explicit ViewSchedule(gr::ViewRange mine);
  // The view to start i-th.
  int view(int i) const { return order_[std::size_t(i)]; }
  // Records how long `view` took (from that view's task; one writer per view).
  void took(int view, double seconds) { seconds_[std::size_t(view - begin_)] = seconds; }
  // Sorts the views by the times recorded, longest first (ties: view order).
  void reorder();

 private:
  int begin_;
  std::vector<double> seconds_;
  std::vector<int> order_;
};

}  // namespace fit
