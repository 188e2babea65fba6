#include "examples/fit/concurrent_views.h"

#include <algorithm>
#include <utility>

#include "autodiff/base/error.h"
#include "ops/ops.h"

namespace fit {

using namespace gr;

namespace {

// dst's values become src's, in place (both float32 of one shape): the
// leaves keep their identity from step to step.
void set_values(Tensor& dst, const Tensor& src) {
  if (src.shape() != dst.shape()) throw ShapeError("fit: the surface changed shape to " + src.describe());
  std::copy_n(std::as_const(src).data<float>(), src.numel(), dst.data<float>());
}

}  // namespace

SharedSurface::SharedSurface(const SurfaceMesh& mesh, const Material& material) : mesh_(mesh), material_(material) {
  const std::int64_t r = mesh.render_to_point.numel();
  leaves_.push_back(Tensor::zeros({r, 3}).set_requires_grad());  // vertices
  leaves_.push_back(Tensor::zeros({r, 3}).set_requires_grad());  // normals
  leaves_.push_back(material.texture.defined() ? material.texture : Tensor::zeros({r, 3}).set_requires_grad());
}

void SharedSurface::update(const Tensor& positions) {
  recorded_ = surface(mesh_, positions, material_);
  set_values(leaves_[0], recorded_.vertices);
  set_values(leaves_[1], recorded_.normals);
  if (recorded_.colours.defined()) set_values(leaves_[2], recorded_.colours);
}

Surface SharedSurface::as_surface(const std::vector<Tensor>& leaves) const {
  Surface s;
  s.vertices = leaves[0], s.normals = leaves[1];
  (material_.texture.defined() ? s.texture : s.colours) = leaves[2];
  return s;
}

void SharedSurface::add_pullback(std::vector<Tensor>& values, std::vector<Tensor>& weights) const {
  values.insert(values.end(), {recorded_.vertices, recorded_.normals});
  weights.insert(weights.end(), {leaves_[0].grad(), leaves_[1].grad()});
  if (recorded_.colours.defined()) values.push_back(recorded_.colours), weights.push_back(leaves_[2].grad());
}

void SharedSurface::zero_grad() {
  leaves_[0].zero_grad();
  leaves_[1].zero_grad();
  if (!material_.texture.defined()) leaves_[2].zero_grad();
}

ViewSchedule::ViewSchedule(ViewRange mine) : begin_(mine.begin), seconds_(std::size_t(mine.end - mine.begin)) {
  for (int v = mine.begin; v < mine.end; ++v) order_.push_back(v);
}

void ViewSchedule::reorder() {
  std::stable_sort(order_.begin(), order_.end(), [&](int a, int b) {
    return seconds_[std::size_t(a - begin_)] > seconds_[std::size_t(b - begin_)];
  });
}

}  // namespace fit
