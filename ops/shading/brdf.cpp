// The BRDFs of brdf.h, term by term as the formulas there read; the tape
// differentiates them.
#include "ops/shading/brdf.h"

#include "ops/tensor/elementwise.h"
#include "ops/shading/arguments.h"
#include "ops/tensor/vector.h"

namespace gr::shading {

using detail::kPi;

Tensor lambert(const Tensor& albedo, const Tensor& normal, const Tensor& light_dir) {
  constexpr const char* op = "shading::lambert";
  detail::check_vectors(albedo, 3, op, "albedo");
  detail::check_vectors(normal, 3, op, "normal");
  detail::check_vectors(light_dir, 3, op, "light_dir");
  detail::check_together(op, {{"albedo", albedo}, {"normal", normal}, {"light_dir", light_dir}});
  return albedo * maximum(dot(normal, light_dir), 0.0) / kPi;
}

Tensor blinn_phong(const Tensor& albedo, const Tensor& specular, const Tensor& shininess, const Tensor& normal,
                   const Tensor& light_dir, const Tensor& view_dir) {
  constexpr const char* op = "shading::blinn_phong";
  detail::check_vectors(albedo, 3, op, "albedo");
  detail::check_vectors(specular, 3, op, "specular");
  detail::check_scalars(shininess, op, "shininess");
  detail::check_vectors(normal, 3, op, "normal");
  detail::check_vectors(light_dir, 3, op, "light_dir");
  detail::check_vectors(view_dir, 3, op, "view_dir");
  detail::check_together(op, {{"albedo", albedo}, {"specular", specular}, {"shininess", shininess},
                              {"normal", normal}, {"light_dir", light_dir}, {"view_dir", view_dir}});
  const Tensor h = normalize(light_dir + view_dir);
  const Tensor n_dot_l = dot(normal, light_dir);  // [..., 1]
  const Tensor lit = n_dot_l > 0.0;               // mask, no gradient
  const Tensor diffuse = albedo * maximum(n_dot_l, 0.0) / kPi;
  return diffuse + specular * pow(maximum(dot(normal, h), 0.0), shininess) * lit;
}

Tensor ggx_distribution(const Tensor& n_dot_h, const Tensor& alpha) {
  detail::check_together("shading::ggx_distribution", {{"n_dot_h", n_dot_h}, {"alpha", alpha}});
  const Tensor a2 = alpha * alpha;
  const Tensor d = n_dot_h * n_dot_h * (a2 - 1.0) + 1.0;
  return a2 / (kPi * d * d);
}

Tensor smith_ggx_correlated(const Tensor& n_dot_v, const Tensor& n_dot_l, const Tensor& alpha) {
  detail::check_together("shading::smith_ggx_correlated", {{"n_dot_v", n_dot_v}, {"n_dot_l", n_dot_l}, {"alpha", alpha}});
  const Tensor a2 = alpha * alpha;
  const Tensor ggx_v = n_dot_l * sqrt(n_dot_v * n_dot_v * (1.0 - a2) + a2);
  const Tensor ggx_l = n_dot_v * sqrt(n_dot_l * n_dot_l * (1.0 - a2) + a2);
  return 0.5 / (ggx_v + ggx_l);
}

Tensor fresnel_schlick(const Tensor& cos_theta, const Tensor& f0) {
  detail::check_together("shading::fresnel_schlick", {{"cos_theta", cos_theta}, {"f0", f0}});
  return f0 + (1.0 - f0) * pow(1.0 - cos_theta, 5.0);
}

Tensor cook_torrance(const Tensor& base_color, const Tensor& metallic, const Tensor& roughness, const Tensor& normal,
                     const Tensor& light_dir, const Tensor& view_dir) {
  constexpr const char* op = "shading::cook_torrance";
  detail::check_vectors(base_color, 3, op, "base_color");
  detail::check_scalars(metallic, op, "metallic");
  detail::check_scalars(roughness, op, "roughness");
  detail::check_vectors(normal, 3, op, "normal");
  detail::check_vectors(light_dir, 3, op, "light_dir");
  detail::check_vectors(view_dir, 3, op, "view_dir");
  detail::check_together(op, {{"base_color", base_color}, {"metallic", metallic}, {"roughness", roughness},
                              {"normal", normal}, {"light_dir", light_dir}, {"view_dir", view_dir}});
  const Tensor r = clamp(roughness, 0.03, 1.0);
  const Tensor alpha = r * r;
  const Tensor h = normalize(light_dir + view_dir);
  const Tensor n_dot_l = maximum(dot(normal, light_dir), 0.0);
  const Tensor n_dot_v = maximum(dot(normal, view_dir), 1e-4);
  const Tensor n_dot_h = maximum(dot(normal, h), 0.0);
  const Tensor v_dot_h = maximum(dot(view_dir, h), 0.0);
  const Tensor f0 = 0.04 * (1.0 - metallic) + base_color * metallic;
  const Tensor f = fresnel_schlick(v_dot_h, f0);
  const Tensor diffuse = (1.0 - f) * (1.0 - metallic) * base_color / kPi;
  const Tensor specular = f * ggx_distribution(n_dot_h, alpha) * smith_ggx_correlated(n_dot_v, n_dot_l, alpha);
  return (diffuse + specular) * n_dot_l;
}

}  // namespace gr::shading
