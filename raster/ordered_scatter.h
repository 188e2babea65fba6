// Deterministic parallel scatter of per-item contributions into per-vertex
// sums (the adjoints' pattern: every pixel or fragment adds to the three
// vertices of its triangle).
//
// Every vertex receives its contributions in item order, whatever the thread
// count, so the sums are bit-identical to a sequential loop over the items.
// Two parallel passes: the items, in fixed blocks, are sorted into lists per
// group of vertices (an entry is item * 3 + corner), then each group adds its
// entries block by block. Neither pass walks all items on every thread.
#pragma once

#include <algorithm>
#include <cstdint>
#include <vector>

#include "autodiff/parallel.h"

namespace gr::raster {

class OrderedScatter {
 public:
  // vertex(i, k): the vertex that corner k (0..2) of item i adds to, or -1
  // for none. add(i, k, v): adds that contribution; called for each vertex's
  // entries in item order, concurrently only for vertices of different groups.
  template <class VertexOf, class Add>
  void run(std::int64_t items, std::int64_t vertices, VertexOf vertex, Add add) {
    if (items <= 0 || vertices <= 0) return;
    // Fixed by the sizes alone; the sums never depend on them, only the speed.
    constexpr std::int64_t kBlockItems = 2048, kMaxBlocks = 64, kMaxGroups = 64;
    const std::int64_t blocks = std::min(kMaxBlocks, (items + kBlockItems - 1) / kBlockItems);
    const std::int64_t per_block = (items + blocks - 1) / blocks;
    const std::int64_t groups = std::min(kMaxGroups, vertices);
    const std::int64_t per_group = (vertices + groups - 1) / groups;
    if (static_cast<std::int64_t>(lists_.size()) < blocks * groups) lists_.resize(static_cast<std::size_t>(blocks * groups));
    parallel_for(0, blocks, 1, [&](std::int64_t b0, std::int64_t b1) {
      for (std::int64_t b = b0; b < b1; ++b) {
        std::vector<std::int64_t>* row = &lists_[static_cast<std::size_t>(b * groups)];
        for (std::int64_t g = 0; g < groups; ++g) row[g].clear();
        const std::int64_t i1 = std::min(items, (b + 1) * per_block);
        for (std::int64_t i = b * per_block; i < i1; ++i)
          for (int k = 0; k < 3; ++k) {
            const std::int64_t v = vertex(i, k);
            if (v >= 0) row[v / per_group].push_back(3 * i + k);
          }
      }
    });
    parallel_for(0, groups, 1, [&](std::int64_t g0, std::int64_t g1) {
      for (std::int64_t g = g0; g < g1; ++g)
        for (std::int64_t b = 0; b < blocks; ++b)
          for (std::int64_t e : lists_[static_cast<std::size_t>(b * groups + g)]) {
            const std::int64_t i = e / 3;
            const int k = static_cast<int>(e - 3 * i);
            add(i, k, vertex(i, k));
          }
    });
  }

 private:
  std::vector<std::vector<std::int64_t>> lists_;  // [block][group] entries, reused across calls
};

}  // namespace gr::raster
