// The last few welded topologies (ops/render/topology_cache.h), each with the
// triangle tensor's stamp and the weld (canonical vertex ids) it was built
// with. A lookup tests the entries of the same triangles, most recent first,
// outside the lock; a miss builds, and keeps the result unless an equal weld
// of the same triangles was kept meanwhile (another thread's build), which it
// returns instead.
#include "ops/render/topology_cache.h"

#include <memory>
#include <vector>

#include "ops/render/recent_entries.h"
#include "ops/render/tensor_stamp.h"
#include "raster/edge_weld.h"

namespace gr::detail {

namespace {

// A weld of a triangle list's vertices and the topology it gives.
struct KeptWeld {
  TensorStamp stamp;
  std::int64_t vertices;
  std::shared_ptr<const std::vector<std::int32_t>> canonical;
  AntialiasTopology topology;
};

RecentEntries<KeptWeld>& kept_welds() {
  static RecentEntries<KeptWeld> kept;  // a few welds per mesh (an open and a closed state), or a few meshes
  return kept;
}

}  // namespace

template <class T>
AntialiasTopology welded_topology(const Tensor& triangles, std::int64_t num_vertices, const T* rows) {
  auto same_triangles = [&](const KeptWeld& e) {
    return e.vertices == num_vertices && e.stamp.matches(triangles);
  };
  // The kept welds of these triangles, tested outside the lock.
  for (const KeptWeld& e : kept_welds().all(same_triangles))
    if (raster::weld_holds(rows, 4, *e.canonical)) {
      kept_welds().find([&](const KeptWeld& k) { return k.topology == e.topology; });  // the most recent now
      return e.topology;
    }
  KeptWeld made{TensorStamp::of(triangles), num_vertices,
                std::make_shared<const std::vector<std::int32_t>>(raster::weld_vertices(rows, num_vertices, 4)),
                nullptr};
  made.topology = std::make_shared<const raster::EdgeTopology>(
      raster::build_edge_topology_welded(triangles.data<std::int32_t>(), triangles.size(0), *made.canonical));
  // Another thread's equal weld of these triangles, kept meanwhile, wins.
  return kept_welds()
      .find_or_keep([&](const KeptWeld& e) { return same_triangles(e) && *e.canonical == *made.canonical; }, made)
      .topology;
}

template AntialiasTopology welded_topology<float>(const Tensor&, std::int64_t, const float*);
template AntialiasTopology welded_topology<double>(const Tensor&, std::int64_t, const double*);

}  // namespace gr::detail
