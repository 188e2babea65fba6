// GPU antialias on a range mode G-buffer (raster/vulkan/frame.h, `whole`):
// the frame rasterized rows first.. of a triangle list (ids numbered from 1
// in the range) and antialias reads the whole list with the ids offset by
// first, so its walks leave the range as the CPU kernels' do on the whole
// list's ids: the CPU's pairs and blends, the same bits as the frame loaded
// with the whole list and the host's ids; forward and adjoint, antialias and
// visibility_antialias. A whole list whose rows are not the frame's, or no
// topology, is refused.
#include <catch2/catch.hpp>

#include <algorithm>
#include <cstring>
#include <vector>

#include "autodiff/base/error.h"
#include "raster/antialias.h"
#include "raster/blended_pairs.h"
#include "raster/procedural.h"
#include "raster/vulkan/frame.h"
#include "raster/vulkan/scenes.h"

using namespace gr;
using namespace gr::raster;
using namespace gr::testing;

namespace {

constexpr int kW = 64, kH = 56, kC = 2;

struct Outputs {
  std::vector<float> out, grad_image, grad_clip;
};

// A range of a closed mesh: rows first..first + count - 1 of `whole`, which
// share edges with the rows outside it.
struct RangeCase {
  Scene whole, range;
  std::int64_t first = 0;
  EdgeTopology topology;  // of the whole list
  std::vector<std::int32_t> global_ids;  // the range's G-buffer ids, indexing the whole list
  std::vector<float> depth;              // its z/w
  RangeCase(std::int64_t first_row, std::int64_t count) : first(first_row) {
    whole = perspective(make_icosphere(2), 1.0, 3.0);
    range.clip = whole.clip;
    range.tris.assign(whole.tris.begin() + 3 * first, whole.tris.begin() + 3 * (first + count));
    topology = build_edge_topology(whole.tris.data(), static_cast<std::int64_t>(whole.tris.size() / 3));
    const CpuGBuffer gb = cpu_gbuffer(range, kW, kH);
    for (std::size_t q = 0; q < gb.id.size(); ++q) {
      global_ids.push_back(gb.id[q] ? gb.id[q] + static_cast<std::int32_t>(first) : 0);
      depth.push_back(gb.rast[4 * q + 2]);
    }
  }
  std::int64_t num_vertices() const { return static_cast<std::int64_t>(whole.clip.size() / 4); }
  vulkan::WholeTriangles whole_list() const {
    return {whole.tris.data(), static_cast<std::int64_t>(whole.tris.size() / 3), first};
  }
};

// The CPU kernels on the whole list with the range's ids made global (what
// the ops run in range mode); sub_list: on the range's triangles alone with
// their own topology instead, which knows no neighbour outside the range.
Outputs on_cpu(const RangeCase& c, bool visibility, const std::vector<float>& image, const std::vector<float>& grad_out,
               bool sub_list = false) {
  const EdgeTopology own = build_edge_topology(c.range.tris.data(), static_cast<std::int64_t>(c.range.tris.size() / 3));
  std::vector<std::int32_t> local_ids(c.global_ids.size());
  for (std::size_t q = 0; q < local_ids.size(); ++q)
    local_ids[q] = c.global_ids[q] ? c.global_ids[q] - static_cast<std::int32_t>(c.first) : 0;
  const Scene& list = sub_list ? c.range : c.whole;
  AntialiasParams<float> p;
  p.image = image.data();
  p.channels = kC;
  p.width = kW;
  p.height = kH;
  p.tri_id = sub_list ? local_ids.data() : c.global_ids.data();
  p.depth = c.depth.data();
  p.clip = c.whole.clip.data();
  p.num_vertices = c.num_vertices();
  p.tris = list.tris.data();
  p.num_tris = static_cast<std::int64_t>(list.tris.size() / 3);
  p.topology = sub_list ? &own : &c.topology;
  Outputs r{std::vector<float>(image.size()), std::vector<float>(image.size()),
            std::vector<float>(static_cast<std::size_t>(4 * c.num_vertices()))};
  BlendedPairs pairs;
  blend_boundaries_forward(visibility, p, r.out.data(), &pairs);
  blend_boundaries_backward(p, pairs, grad_out.data(), AntialiasGrads<float>{r.grad_image.data(), r.grad_clip.data()});
  return r;
}

Outputs antialias_on(vulkan::Frame& frame, const RangeCase& c, bool visibility, const std::vector<float>& image,
                     const std::vector<float>& grad_out, const vulkan::WholeTriangles* whole) {
  Outputs r{std::vector<float>(image.size()), std::vector<float>(image.size()),
            std::vector<float>(static_cast<std::size_t>(4 * c.num_vertices()))};
  frame.antialias(image.data(), kC, r.out.data(), &c.topology, visibility, whole);
  frame.antialias_backward(grad_out.data(), r.grad_image.data(), r.grad_clip.data());
  return r;
}

bool same_bits(const std::vector<float>& a, const std::vector<float>& b) {
  return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(float)) == 0;
}

bool same_bits(const Outputs& a, const Outputs& b) {
  return same_bits(a.out, b.out) && same_bits(a.grad_image, b.grad_image) && same_bits(a.grad_clip, b.grad_clip);
}

}  // namespace

TEST_CASE("GPU antialias of a range's G-buffer walks the whole list as the CPU does", "[vulkan][range]") {
  if (!shared_gpu()) return;
  const std::int64_t M = static_cast<std::int64_t>(perspective(make_icosphere(2), 1.0, 3.0).tris.size() / 3);
  struct Range {
    std::int64_t first, count;
  };
  for (const Range& r : {Range{M / 3, M / 3}, Range{0, M / 2}, Range{M / 2, M - M / 2}}) {
    const std::int64_t first = r.first, count = r.count;
    const RangeCase c(first, count);
    for (bool visibility : {false, true}) {
      INFO("rows " << first << " to " << first + count - 1 << " of " << M << (visibility ? ", visibility" : ""));
      const std::vector<float> image = random_values(kW * kH * kC, 5), grad_out = random_values(kW * kH * kC, 6);
      const Outputs cpu = on_cpu(c, visibility, image, grad_out);
      // The walks leave the range: a topology of its triangles alone would blend elsewhere.
      REQUIRE_FALSE(same_bits(on_cpu(c, visibility, image, grad_out, true).out, cpu.out));
      vulkan::Frame frame(shared_gpu());
      frame.rasterize(c.range.params(kW, kH));
      const vulkan::WholeTriangles whole = c.whole_list();
      const Outputs gpu = antialias_on(frame, c, visibility, image, grad_out, &whole);
      CHECK(relative_error(gpu.out, cpu.out) <= 1e-6);
      CHECK(relative_error(gpu.grad_image, cpu.grad_image) <= 1e-5);
      CHECK(relative_error(gpu.grad_clip, cpu.grad_clip) <= 1e-5);
      // The same bits as the whole list's G-buffer loaded with the host's ids, and run again.
      vulkan::Frame loaded(shared_gpu());
      loaded.load_gbuffer(c.whole.params(kW, kH), {}, c.global_ids.data(), nullptr, 2, c.depth.data(), nullptr);
      CHECK(same_bits(antialias_on(loaded, c, visibility, image, grad_out, nullptr), gpu));
      CHECK(same_bits(antialias_on(frame, c, visibility, image, grad_out, &whole), gpu));
      // The whole list went up once, besides the range's own.
      CHECK(frame.triangle_uploads().uploads == 2);
      CHECK(frame.triangle_uploads().bytes == 12 * (count + M));
    }
  }
}

TEST_CASE("GPU antialias refuses a whole list whose rows are not the range's and one without its topology",
          "[vulkan][range]") {
  if (!shared_gpu()) return;
  const std::int64_t M = static_cast<std::int64_t>(perspective(make_icosphere(2), 1.0, 3.0).tris.size() / 3);
  const RangeCase c(M / 4, M / 4);
  vulkan::Frame frame(shared_gpu());
  frame.rasterize(c.range.params(kW, kH));
  const std::vector<float> image = random_values(kW * kH * kC, 7);
  vulkan::WholeTriangles shifted = c.whole_list();
  shifted.first += 1;
  REQUIRE_THROWS_WITH(frame.antialias(image.data(), kC, nullptr, &c.topology, false, &shifted),
                      Catch::Contains("are not the frame's triangles"));
  vulkan::WholeTriangles beyond = c.whole_list();
  beyond.first = M - M / 4 + 1;
  REQUIRE_THROWS_WITH(frame.antialias(image.data(), kC, nullptr, &c.topology, false, &beyond),
                      Catch::Contains("no range"));
  const vulkan::WholeTriangles whole = c.whole_list();
  REQUIRE_THROWS_WITH(frame.antialias(image.data(), kC, nullptr, nullptr, false, &whole),
                      Catch::Contains("topology"));
  // A whole list that is the frame's own changes nothing.
  vulkan::Frame own(shared_gpu());
  own.rasterize(c.whole.params(kW, kH));
  const vulkan::WholeTriangles itself{c.whole.tris.data(), M, 0};
  own.antialias(image.data(), kC, nullptr, &c.topology, false, &itself);
  CHECK(own.triangle_uploads().uploads == 1);
}
