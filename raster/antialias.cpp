// Silhouette antialiasing: edge topology, the forward blend over pixel pairs
// next to a tri_id change, and its adjoint (see antialias.h for formulas).
// Pairs are found and evaluated per row in parallel, then applied in row order;
// the adjoint computes per-pair contributions in parallel and adds them in pair
// order, so results are bit-identical for any thread count.
#include "raster/antialias.h"

#include <algorithm>
#include <atomic>
#include <cassert>
#include <cmath>
#include <limits>
#include <optional>
#include <string>
#include <utility>

#include "autodiff/base/error.h"
#include "autodiff/base/parallel.h"
#include "raster/detail/guarded_math.h"
#include "raster/project.h"
#include "raster/detail/rasterize_setup.h"
#include "raster/detail/silhouette_mask.h"
#include "raster/detail/surface_walk.h"
#include "raster/edge_weld.h"

namespace gr::raster {

namespace {

using detail::finite_cast;
using detail::safe_inv;

// The walk along a pixel pair's segment (silhouette criterion, exit edges)
// and the axis ownership live in raster/detail/surface_walk.h, shared with
// visibility_antialias.
using detail::edge_fn;

detail::ScratchPool<detail::Vertices> g_vertex_pool;

}  // namespace

// ---------------------------------------------------------------------------
// Edge topology

namespace {
std::atomic<std::uint64_t> g_topology_serial{0};  // the last serial given (0: none yet)
}  // namespace

namespace {
// The walks index triangles by neighbour entries (tris[n], tris + 3 (n / 3)):
// one beyond the triangles would read outside them, so a hand-made table is
// checked once here and every kernel can trust it.
void check_neighbours(std::int64_t num_tris, const std::vector<std::int64_t>& neighbour) {
  if (num_tris < 0 || neighbour.size() != 3 * static_cast<std::size_t>(num_tris))
    throw ValueError("EdgeTopology: neighbour has " + std::to_string(neighbour.size()) +
                     " entries, expected 3 per triangle for " + std::to_string(num_tris) + " triangles");
  for (std::size_t i = 0; i < neighbour.size(); ++i)
    if (neighbour[i] < kNonManifoldEdge || neighbour[i] >= 3 * num_tris)
      throw IndexError("EdgeTopology: neighbour[" + std::to_string(i) + "] = " + std::to_string(neighbour[i]) +
                       " is neither an edge slot in [0, " + std::to_string(3 * num_tris) +
                       ") nor kBoundaryEdge / kNonManifoldEdge");
}
}  // namespace

EdgeTopology::EdgeTopology(std::int64_t num_tris, std::vector<std::int64_t> neighbour)
    : num_tris_(num_tris), neighbour_(std::move(neighbour)) {
  check_neighbours(num_tris_, neighbour_);
  serial_ = ++g_topology_serial;
}

EdgeTopology::EdgeTopology(EdgeTopology&& other) noexcept
    : num_tris_(std::exchange(other.num_tris_, 0)),
      neighbour_(std::exchange(other.neighbour_, {})),
      serial_(std::exchange(other.serial_, 0)) {}

EdgeTopology& EdgeTopology::operator=(EdgeTopology&& other) noexcept {
  num_tris_ = std::exchange(other.num_tris_, 0);
  neighbour_ = std::exchange(other.neighbour_, {});
  serial_ = std::exchange(other.serial_, 0);
  return *this;
}

template <class T>
EdgeTopology build_edge_topology(const std::int32_t* tris, std::int64_t num_tris, std::int64_t num_vertices,
                                 const T* pos, int dims) {
  return build_edge_topology_welded(tris, num_tris, weld_vertices(pos, num_vertices, dims));
}

EdgeTopology build_edge_topology_welded(const std::int32_t* tris, std::int64_t num_tris,
                                        const std::vector<std::int32_t>& canon) {
  const std::int64_t num_vertices = static_cast<std::int64_t>(canon.size());
  std::vector<std::int64_t> neighbour(static_cast<std::size_t>(3 * num_tris), kBoundaryEdge);

  // Bucket the undirected edges by their smaller canonical vertex (counting sort).
  auto ends = [&](std::int64_t e, std::int32_t* lo, std::int32_t* hi) {
    const std::int32_t* tri = tris + 3 * (e / 3);
    const int k = static_cast<int>(e % 3);
    const std::int32_t a = canon[tri[(k + 1) % 3]], b = canon[tri[(k + 2) % 3]];
    *lo = std::min(a, b);
    *hi = std::max(a, b);
  };
  std::vector<std::int64_t> start(static_cast<std::size_t>(num_vertices) + 1, 0);
  for (std::int64_t e = 0; e < 3 * num_tris; ++e) {
    std::int32_t lo, hi;
    ends(e, &lo, &hi);
    if (lo == hi)
      neighbour[e] = kNonManifoldEdge;  // zero-length edge: never crossed
    else
      ++start[lo + 1];
  }
  for (std::int64_t i = 0; i < num_vertices; ++i) start[i + 1] += start[i];
  struct Entry {
    std::int32_t hi;
    std::int64_t edge;
  };
  std::vector<Entry> entries(static_cast<std::size_t>(start[num_vertices]));
  {
    std::vector<std::int64_t> fill(start.begin(), start.end() - 1);
    for (std::int64_t e = 0; e < 3 * num_tris; ++e) {
      std::int32_t lo, hi;
      ends(e, &lo, &hi);
      if (lo != hi) entries[fill[lo]++] = {hi, e};
    }
  }
  // Within each bucket, edges with the same far vertex are the same edge.
  parallel_for(0, num_vertices, 4096, [&](std::int64_t v0, std::int64_t v1) {
    for (std::int64_t v = v0; v < v1; ++v) {
      Entry* b = entries.data() + start[v];
      Entry* e = entries.data() + start[v + 1];
      std::sort(b, e, [](const Entry& x, const Entry& y) { return x.hi != y.hi ? x.hi < y.hi : x.edge < y.edge; });
      for (Entry* g = b; g != e;) {
        Entry* g1 = g;
        while (g1 != e && g1->hi == g->hi) ++g1;
        if (g1 - g == 2) {
          neighbour[g[0].edge] = g[1].edge;
          neighbour[g[1].edge] = g[0].edge;
        } else if (g1 - g > 2) {
          for (Entry* x = g; x != g1; ++x) neighbour[x->edge] = kNonManifoldEdge;
        }
        g = g1;
      }
    }
  });
  return EdgeTopology(num_tris, std::move(neighbour));
}

EdgeTopology build_edge_topology(const std::int32_t* tris, std::int64_t num_tris, std::int64_t num_vertices) {
  return build_edge_topology<double>(tris, num_tris, num_vertices, nullptr, 0);
}

EdgeTopology build_edge_topology(const std::int32_t* tris, std::int64_t num_tris) {
  const std::int64_t n = 3 * num_tris;
  std::int32_t largest = -1;
  for (std::int64_t i = 0; i < n; ++i) largest = std::max(largest, tris[i]);
  if (largest < n) return build_edge_topology(tris, num_tris, std::int64_t(largest) + 1);  // dense enough
  // Renumber the used vertices 0, 1, ... in index order: edges pair up by
  // their ends' order alone, so the neighbours are the same.
  std::vector<std::int32_t> used(tris, tris + n);
  std::sort(used.begin(), used.end());
  used.erase(std::unique(used.begin(), used.end()), used.end());
  std::vector<std::int32_t> dense(static_cast<std::size_t>(n));
  parallel_for(0, n, kElementwiseGrain, [&](std::int64_t lo, std::int64_t hi) {
    for (std::int64_t i = lo; i < hi; ++i)
      dense[i] = static_cast<std::int32_t>(std::lower_bound(used.begin(), used.end(), tris[i]) - used.begin());
  });
  return build_edge_topology(dense.data(), num_tris, static_cast<std::int64_t>(used.size()));
}

std::size_t edge_topology_bytes(std::int64_t num_tris) {
  // Per edge: the neighbour (8), a bucket entry (16), at most one vertex's
  // bucket start (8) and canonical id (4), the renumbering's two copies (8).
  return static_cast<std::size_t>(3 * std::max<std::int64_t>(num_tris, 0)) * 44 + 64;
}

// ---------------------------------------------------------------------------
// Forward

template <class T>
void antialias_forward(const AntialiasParams<T>& prm, T* out, std::vector<AntialiasPair>* pairs_out,
                       AntialiasStats* stats) {
  assert(prm.width >= 1 && prm.height >= 1 && prm.channels >= 1 && prm.topology &&
         prm.topology->num_tris() == prm.num_tris);
  const T *image = prm.image, *depth = prm.depth;
  const std::int32_t *tri_id = prm.tri_id, *tris = prm.tris;
  const EdgeTopology& topology = *prm.topology;
  const int W = prm.width, H = prm.height, C = prm.channels;
  const std::int64_t P = static_cast<std::int64_t>(W) * H;
  // The rasterizer's projection of clip when the caller kept it, else our
  // own, in buffers reused across calls (issue 31: projecting, allocating
  // and zeroing were fixed costs of every view).
  std::optional<detail::ScratchPool<detail::Vertices>::Lease> own;
  if (!prm.projected) {
    own.emplace(g_vertex_pool.take());
    detail::project_vertices_into(prm.clip, prm.num_vertices, W, H, &**own, prm.y_up);
  }
  const detail::Vertices& v = prm.projected ? *prm.projected : **own;
  detail::SurfaceSides sides(prm.num_tris);

  // Issue 31: only pairs next to a half-edge where a walk can end "Silhouette"
  // need their walk (raster/detail/silhouette_mask.h), when the half-edge pass
  // costs less than the walks it saves. The same pairs, blends and order.
  const detail::SilhouettePrefilter mode = detail::g_silhouette_prefilter.load(std::memory_order_relaxed);
  std::vector<std::atomic<std::uint8_t>> mask;
  bool masked = false;
  // (2 P bounds the candidates: no count when even that would not pay.)
  const bool prefilter = mode == detail::SilhouettePrefilter::Always ||
                         (mode == detail::SilhouettePrefilter::Auto && detail::prefilter_pays(2 * P, prm.num_tris) &&
                          detail::prefilter_pays(detail::count_id_boundaries(tri_id, W, H), prm.num_tris));
  if (prefilter) {
    mask = std::vector<std::atomic<std::uint8_t>>(static_cast<std::size_t>(P));
    masked = detail::build_silhouette_mask(v, tris, prm.num_tris, topology, W, H, sides, mask);
  }
  std::atomic<std::int64_t> skipped{0};

  // Unchanged pixels: a plain copy.
  parallel_for(0, P * C, kElementwiseGrain, [&](std::int64_t lo, std::int64_t hi) {
    std::copy(image + lo, image + hi, out + lo);
  });

  // The pair (p, q): starting in the front triangle at its pixel centre, walk
  // along the segment across interior edges (the surface continues) until a
  // silhouette edge is crossed before the other centre (blend, if the pair's
  // axis owns that edge) or not (none).
  auto evaluate = [&](std::int64_t p, std::int64_t q, bool horizontal, std::vector<AntialiasPair>& found) {
    if (masked && !mask[p].load(std::memory_order_relaxed) && !mask[q].load(std::memory_order_relaxed)) {
      if (mode == detail::SilhouettePrefilter::Always) skipped.fetch_add(1, std::memory_order_relaxed);  // tests count
      return;
    }
    const std::int32_t ip = tri_id[p], iq = tri_id[q];
    // Front: smaller (depth, id) key; background (id 0) is behind everything.
    const bool p_front = iq == 0 || (ip != 0 && (depth[p] < depth[q] || (depth[p] == depth[q] && ip < iq)));
    const std::int64_t in = p_front ? p : q, outp = p_front ? q : p;
    // Pixel centres (q is p's right or lower neighbour: one division).
    const std::int64_t py = p / W, px = p - py * W;
    const std::int64_t qx = horizontal ? px + 1 : px, qy = horizontal ? py : py + 1;
    const double cix = double(p_front ? px : qx) + 0.5, ciy = double(p_front ? py : qy) + 0.5;
    const double cox = double(p_front ? qx : px) + 0.5, coy = double(p_front ? qy : py) + 0.5;
    const detail::WalkEnd e = detail::walk_surface(v, tris, topology, W, H, (p_front ? ip : iq) - 1, (p_front ? iq : ip) - 1, cix, ciy,
                                                   cox, coy, nullptr, &sides);
    if (e.kind != detail::WalkEnd::Kind::Silhouette) return;
    const double* sa = &v.screen[3 * static_cast<std::size_t>(e.a)];
    const double* sb = &v.screen[3 * static_cast<std::size_t>(e.b)];
    if (detail::pair_owns_direction(horizontal, sb[0] - sa[0], sb[1] - sa[1])) found.push_back({in, outp, e.a, e.b, e.t});
  };

  std::vector<std::vector<AntialiasPair>> rows;
  const std::int64_t candidates = detail::for_each_id_boundary(tri_id, W, H, rows, evaluate);

  // Apply in row order (a pixel can be written by up to four pairs).
  std::size_t total = 0;
  for (const auto& r : rows) total += r.size();
  if (pairs_out) pairs_out->reserve(pairs_out->size() + total);
  for (const auto& r : rows)
    for (const AntialiasPair& pr : r) {
      detail::apply_blend(detail::blend_step(pr), image, out, C);
      if (pairs_out) pairs_out->push_back(pr);
    }
  detail::g_prefilter_skipped_walks.fetch_add(skipped.load(), std::memory_order_relaxed);
  if (stats) {
    stats->candidate_pairs = candidates;
    stats->blended_pairs = static_cast<std::int64_t>(total);
  }
}

// ---------------------------------------------------------------------------
// Adjoint

template <class T>
void antialias_backward(const AntialiasParams<T>& prm, const std::vector<AntialiasPair>& pairs, const T* grad_out,
                        const AntialiasGrads<T>& grads) {
  T* grad_image = grads.image;
  T* grad_clip = grads.clip;
  const T *image = prm.image, *clip = prm.clip;
  const std::int64_t num_vertices = prm.num_vertices;
  const int W = prm.width, H = prm.height, C = prm.channels;
  const std::int64_t P = static_cast<std::int64_t>(W) * H;
  const std::int64_t n_pairs = static_cast<std::int64_t>(pairs.size());
  // Colours: identity plus the blend weights, in pair order.
  if (grad_image) detail::blend_image_adjoint(pairs, grad_out, grad_image, P, C);
  if (!grad_clip || n_pairs == 0) return;

  // Edge vertices: per-pair screen gradients in parallel ...
  const double hw = 0.5 * W, hh = 0.5 * H;
  const bool y_up = prm.y_up;
  std::vector<double> contrib(static_cast<std::size_t>(4 * n_pairs), 0.0);
  std::vector<std::uint8_t> live(static_cast<std::size_t>(n_pairs), 0);
  parallel_for(0, n_pairs, 2048, [&](std::int64_t lo, std::int64_t hi) {
    for (std::int64_t i = lo; i < hi; ++i) {
      const AntialiasPair& pr = pairs[i];
      const std::int64_t target = detail::blend_step(pr).target;
      // dL/dt = g[target] . (image[inside] - image[outside]); zero: skip.
      double gt = 0.0;
      for (int c = 0; c < C; ++c)
        gt += double(grad_out[target * C + c]) * (double(image[pr.inside * C + c]) - double(image[pr.outside * C + c]));
      if (gt == 0.0) continue;
      // Screen positions exactly as the forward projected them.
      const T* ca = clip + 4 * static_cast<std::int64_t>(pr.a);
      const T* cb = clip + 4 * static_cast<std::int64_t>(pr.b);
      const double ya = detail::seen_y(double(ca[1]), y_up), yb = detail::seen_y(double(cb[1]), y_up);
      const double sa[2] = {hw * (1.0 + double(ca[0]) / double(ca[3])), hh * (1.0 - ya / double(ca[3]))};
      const double sb[2] = {hw * (1.0 + double(cb[0]) / double(cb[3])), hh * (1.0 - yb / double(cb[3]))};
      const double cix = double(pr.inside % W) + 0.5, ciy = double(pr.inside / W) + 0.5;
      const double cox = double(pr.outside % W) + 0.5, coy = double(pr.outside / W) + 0.5;
      // t = E_i / (E_i - E_o): quotient rule.
      const double ei = edge_fn(cix, ciy, sa, sb), eo = edge_fn(cox, coy, sa, sb);
      const double inv_d = safe_inv(ei - eo);
      const double g_ei = -eo * inv_d * inv_d * gt, g_eo = ei * inv_d * inv_d * gt;
      // Partials of E(q; a, b) w.r.t. the edge's endpoints.
      double* o = &contrib[4 * i];
      o[0] = g_ei * (ciy - sb[1]) + g_eo * (coy - sb[1]);
      o[1] = g_ei * (sb[0] - cix) + g_eo * (sb[0] - cox);
      o[2] = g_ei * (sa[1] - ciy) + g_eo * (sa[1] - coy);
      o[3] = g_ei * (cix - sa[0]) + g_eo * (cox - sa[0]);
      live[i] = 1;
    }
  });
  // ... added per vertex in pair order (deterministic).
  std::vector<double> acc(static_cast<std::size_t>(2 * num_vertices), 0.0);
  bool any = false;
  for (std::int64_t i = 0; i < n_pairs; ++i) {
    if (!live[i]) continue;
    any = true;
    const double* o = &contrib[4 * i];
    acc[2 * static_cast<std::size_t>(pairs[i].a)] += o[0];
    acc[2 * static_cast<std::size_t>(pairs[i].a) + 1] += o[1];
    acc[2 * static_cast<std::size_t>(pairs[i].b)] += o[2];
    acc[2 * static_cast<std::size_t>(pairs[i].b) + 1] += o[3];
  }
  if (!any) return;
  // Screen -> NDC -> clip with the projection adjoints (edge vertices have w > 0).
  screen_to_clip_backward(clip, num_vertices, W, H, acc.data(), 2, grad_clip, y_up);
}

#define GR_INSTANTIATE(T)                                                                                      \
  template EdgeTopology build_edge_topology<T>(const std::int32_t*, std::int64_t, std::int64_t, const T*, int); \
  template void antialias_forward<T>(const AntialiasParams<T>&, T*, std::vector<AntialiasPair>*, AntialiasStats*); \
  template void antialias_backward<T>(const AntialiasParams<T>&, const std::vector<AntialiasPair>&, const T*, \
                                      const AntialiasGrads<T>&);
GR_INSTANTIATE(float)
GR_INSTANTIATE(double)
#undef GR_INSTANTIATE

}  // namespace gr::raster
