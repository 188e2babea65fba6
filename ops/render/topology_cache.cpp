// The last few welded topologies (ops/render/topology_cache.h), each with the
// triangle tensor's stamp and the weld (canonical vertex ids) it was built
// with. A lookup tests the entries of the same triangles, most recent first,
// outside the lock; a miss builds, and keeps the result unless an equal weld
// of the same triangles was kept meanwhile (another thread's build), which it
// returns instead.
#include "ops/render/topology_cache.h"

#include <algorithm>
#include <memory>
#include <mutex>
#include <vector>

#include "ops/render/tensor_stamp.h"
#include "raster/edge_weld.h"

namespace gr::detail {

namespace {

class WeldedTopologyCache {
 public:
  template <class T>
  AntialiasTopology get(const Tensor& triangles, std::int64_t n, const T* rows) {
    for (const Entry& e : candidates(triangles, n))
      if (raster::weld_holds(rows, 4, *e.canonical)) {
        touch(e.topology);
        return e.topology;
      }
    Entry e{TensorStamp::of(triangles), n,
            std::make_shared<const std::vector<std::int32_t>>(raster::weld_vertices(rows, n, 4)), nullptr};
    e.topology = std::make_shared<const raster::EdgeTopology>(
        raster::build_edge_topology_welded(triangles.data<std::int32_t>(), triangles.size(0), *e.canonical));
    std::lock_guard<std::mutex> lock(mutex_);
    for (std::size_t i = 0; i < entries_.size(); ++i)
      if (same_triangles(entries_[i], triangles, n) && *entries_[i].canonical == *e.canonical) {
        std::rotate(entries_.begin(), entries_.begin() + i, entries_.begin() + i + 1);  // most recent first
        return entries_.front().topology;
      }
    entries_.insert(entries_.begin(), e);
    if (entries_.size() > kEntries) entries_.pop_back();
    return e.topology;
  }

 private:
  // A few welds per mesh (e.g. an open and a closed state), or a few meshes.
  static constexpr std::size_t kEntries = 4;
  struct Entry {
    TensorStamp stamp;
    std::int64_t vertices;
    std::shared_ptr<const std::vector<std::int32_t>> canonical;
    AntialiasTopology topology;
  };

  static bool same_triangles(const Entry& e, const Tensor& triangles, std::int64_t n) {
    return e.vertices == n && e.stamp.matches(triangles);
  }

  // The entries of these triangles, most recent first (copies: tested unlocked).
  std::vector<Entry> candidates(const Tensor& triangles, std::int64_t n) {
    std::lock_guard<std::mutex> lock(mutex_);
    entries_.erase(std::remove_if(entries_.begin(), entries_.end(), [](const Entry& e) { return e.stamp.stale(); }),
                   entries_.end());
    std::vector<Entry> found;
    for (const Entry& e : entries_)
      if (same_triangles(e, triangles, n)) found.push_back(e);
    return found;
  }

  // Moves the entry holding `topology` (if still kept) to the front.
  void touch(const AntialiasTopology& topology) {
    std::lock_guard<std::mutex> lock(mutex_);
    for (std::size_t i = 0; i < entries_.size(); ++i)
      if (entries_[i].topology == topology) {
        std::rotate(entries_.begin(), entries_.begin() + i, entries_.begin() + i + 1);
        return;
      }
  }

  std::mutex mutex_;
  std::vector<Entry> entries_;
};

WeldedTopologyCache& cache() {
  static WeldedTopologyCache c;
  return c;
}

}  // namespace

template <class T>
AntialiasTopology welded_topology(const Tensor& triangles, std::int64_t num_vertices, const T* rows) {
  return cache().get(triangles, num_vertices, rows);
}

template AntialiasTopology welded_topology<float>(const Tensor&, std::int64_t, const float*);
template AntialiasTopology welded_topology<double>(const Tensor&, std::int64_t, const double*);

}  // namespace gr::detail
