// Deterministic parallel grouping for the adjoints that send per-pixel terms
// to triangle vertices (docs/determinism.md, "Scatter by gathering").
//
// bucket_items is a stable counting sort: bucket k lists, in ascending order,
// the items i with key(i) == k. That output is the unique ordering by
// (key, item), so it does not depend on how the work is split: the counting
// runs over num_threads() item ranges in parallel (a histogram per range,
// offsets range by range), and any split gives the same buckets bit for bit.
// Sums taken over a bucket in its order are therefore thread-count independent.
// The non-empty buckets are listed in the order of their first items, which
// for pixels keyed by triangle is a sweep down the image: walking triangles in
// that order touches the pixel rows near each other (cache-friendly), and the
// order does not depend on how the triangles are numbered.
#pragma once

#include <algorithm>
#include <cstdint>
#include <vector>

#include "autodiff/base/parallel.h"

namespace gr::raster::detail {

struct Buckets {
  std::vector<std::int64_t> start;     // num_keys + 1: bucket k is item[start[k], start[k+1])
  std::vector<std::int32_t> item;      // the grouped items
  std::vector<std::int32_t> nonempty;  // keys with at least one item, by ascending first item
  std::vector<std::int32_t> counts;    // scratch: one histogram per item range
  std::vector<std::vector<std::int32_t>> firsts;  // scratch: per range, keys first met there
};

// Groups items [0, n) by key(i) in [0, num_keys); key(i) < 0 leaves item i
// out. Item indices and keys must fit int32 (the callers' pixel, corner and
// triangle counts do). Reuses out's buffers (no allocation once big enough).
template <class Key>
void bucket_items(std::int64_t n, std::int64_t num_keys, const Key& key, Buckets* out) {
  // Item ranges: one per thread, at least 16384 items each.
  const std::int64_t parts =
      std::max<std::int64_t>(1, std::min<std::int64_t>(num_threads(), n / 16384));
  const std::int64_t K = num_keys;
  auto range = [&](std::int64_t q, std::int64_t* lo, std::int64_t* hi) {
    *lo = n * q / parts;
    *hi = n * (q + 1) / parts;
  };
  std::vector<std::int32_t>& counts = out->counts;
  counts.resize(static_cast<std::size_t>(parts * K));
  // 1. A histogram of keys per item range.
  parallel_for(0, parts, 1, [&](std::int64_t q0, std::int64_t q1) {
    for (std::int64_t q = q0; q < q1; ++q) {
      std::int32_t* c = counts.data() + q * K;
      std::fill(c, c + K, 0);
      std::int64_t lo, hi;
      range(q, &lo, &hi);
      for (std::int64_t i = lo; i < hi; ++i) {
        const std::int64_t k = key(i);
        if (k >= 0) ++c[k];
      }
    }
  });
  // 2. Bucket starts: exclusive prefix sum of the totals (one range: the
  // counts become the fill cursors in the same pass, issue 31: a fixed cost
  // per key of every adjoint that groups pixels by triangle).
  std::vector<std::int64_t>& start = out->start;
  start.resize(static_cast<std::size_t>(K + 1));
  std::int64_t total = 0;
  if (parts == 1) {
    std::int32_t* const c = counts.data();
    std::int64_t* const s = start.data();
    for (std::int64_t k = 0; k < K; ++k) {
      const std::int32_t n_k = c[k];
      s[k] = total;
      c[k] = static_cast<std::int32_t>(total);
      total += n_k;
    }
  } else {
    for (std::int64_t k = 0; k < K; ++k) {
      start[k] = total;
      for (std::int64_t q = 0; q < parts; ++q) total += counts[q * K + k];
    }
  }
  start[K] = total;
  // 3. Each range's first slot in each bucket: ranges in item order.
  if (parts > 1)
    parallel_for(0, K, 4096, [&](std::int64_t k0, std::int64_t k1) {
      for (std::int64_t k = k0; k < k1; ++k) {
        std::int64_t at = start[k];
        for (std::int64_t q = 0; q < parts; ++q) {
          const std::int32_t c = counts[q * K + k];
          counts[q * K + k] = static_cast<std::int32_t>(at);
          at += c;
        }
      }
    });
  // 4. Place the items, each range in ascending order; an item placed at its
  // bucket's start is the bucket's first.
  out->item.resize(static_cast<std::size_t>(total));
  out->firsts.resize(static_cast<std::size_t>(std::max<std::int64_t>(parts, out->firsts.size())));
  parallel_for(0, parts, 1, [&](std::int64_t q0, std::int64_t q1) {
    for (std::int64_t q = q0; q < q1; ++q) {
      std::int32_t* next = counts.data() + q * K;
      std::vector<std::int32_t>& firsts = out->firsts[q];
      firsts.clear();
      std::int64_t lo, hi;
      range(q, &lo, &hi);
      for (std::int64_t i = lo; i < hi; ++i) {
        const std::int64_t k = key(i);
        if (k < 0) continue;
        const std::int32_t at = next[k]++;
        if (at == start[k]) firsts.push_back(static_cast<std::int32_t>(k));
        out->item[at] = static_cast<std::int32_t>(i);
      }
    }
  });
  // 5. Non-empty keys by first item: the ranges' lists in range order.
  out->nonempty.clear();
  for (std::int64_t q = 0; q < parts; ++q)
    out->nonempty.insert(out->nonempty.end(), out->firsts[q].begin(), out->firsts[q].end());
}

}  // namespace gr::raster::detail
