// The time_error scene rendered by the exact reference, and its MSE loss.
#include "bench/time_error_exact.h"

#include <vector>

#include "autodiff/tape.h"

namespace gr::bench {

ExactImage exact_scene_image(const TimeErrorScene& scene, const Tensor& points, const Tensor& colours,
                         const ExactReferenceOptions& options) {
  NoGradGuard no_grad;
  ExactReferenceOptions culled = options;
  culled.cull = scene.cull();  // the render's culling, always
  return exact_box_filtered(scene.clip_positions(points), scene.triangles(), scene.vertex_colours(colours),
                            scene.width(), scene.height(), scene.background(), culled);
}

SceneLoss exact_scene_loss(const TimeErrorScene& scene, const Tensor& target) {
  return [&scene, target = target.to_vector()](const Tensor& points, const Tensor& colours) {
    const std::vector<double> image = exact_scene_image(scene, points, colours).image.to_vector();
    double sum = 0;
    for (std::size_t i = 0; i < image.size(); ++i) sum += (image[i] - target[i]) * (image[i] - target[i]);
    return sum / double(image.size());
  };
}

}  // namespace gr::bench
