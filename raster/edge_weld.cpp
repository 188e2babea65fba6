// Vertex welding by position rows (raster/edge_weld.h): the sort that names
// each row's vertices by their smallest index, and the linear test that a
// kept naming still describes new rows.
#include "raster/edge_weld.h"

#include <algorithm>
#include <cstring>
#include <numeric>
#include <type_traits>

#include "autodiff/base/storage.h"

namespace gr::raster {

namespace {

template <class T>
bool rows_equal(const T* pos, int dims, std::int64_t a, std::int64_t b) {
  for (int d = 0; d < dims; ++d)
    if (pos[a * dims + d] != pos[b * dims + d]) return false;
  return true;
}

// A hash of a row consistent with rows_equal (FxHash's rotate, xor and
// multiply per component): +0 for -0 (equal under ==); rows are finite, so
// equal rows have equal bits otherwise.
template <class T>
std::uint64_t row_hash(const T* row, int dims) {
  std::uint64_t h = 0;
  for (int d = 0; d < dims; ++d) {
    const T x = row[d] == T(0) ? T(0) : row[d];
    std::conditional_t<sizeof(T) == 8, std::uint64_t, std::uint32_t> bits;
    std::memcpy(&bits, &x, sizeof(T));
    h = (((h << 5) | (h >> 59)) ^ bits) * 0x517cc1b727220a95ull;
  }
  return h;
}

// A slot of an open-addressing table of vertices by row: the hash's low 32
// bits (to skip most row comparisons) and the vertex (-1: empty).
struct Slot {
  std::uint32_t tag;
  std::int32_t vertex;
};

}  // namespace

template <class T>
std::vector<std::int32_t> weld_vertices(const T* pos, std::int64_t num_vertices, int dims) {
  std::vector<std::int32_t> canon(static_cast<std::size_t>(num_vertices));
  std::iota(canon.begin(), canon.end(), 0);
  if (!pos || dims < 1) return canon;
  auto row_less = [&](std::int32_t a, std::int32_t b) {
    for (int d = 0; d < dims; ++d) {
      const T pa = pos[std::int64_t(a) * dims + d], pb = pos[std::int64_t(b) * dims + d];
      if (pa != pb) return pa < pb;
    }
    return false;
  };
  std::vector<std::int32_t> order(canon);
  std::sort(order.begin(), order.end(), [&](std::int32_t a, std::int32_t b) {
    if (row_less(a, b)) return true;
    if (row_less(b, a)) return false;
    return a < b;
  });
  // Each run of equal rows, in index order: its first (smallest) index names it.
  for (std::size_t i = 1; i < order.size(); ++i)
    if (!row_less(order[i - 1], order[i])) canon[order[i]] = canon[order[i - 1]];
  return canon;
}

// weld_vertices' classes are the classes of ==, named by their smallest
// member. `canonical` is that naming when (1) each v names some c <= v that
// names itself, with row v == row c, so each of its classes lies within one
// class of ==, and (2) the rows of the vertices naming themselves are pairwise
// distinct, so no two of its classes lie within the same one: the two
// partitions are then the same, and so are the smallest members.
template <class T>
bool weld_holds(const T* pos, int dims, const std::vector<std::int32_t>& canon) {
  const std::int64_t n = static_cast<std::int64_t>(canon.size());
  if (!pos || dims < 1) {
    for (std::int64_t v = 0; v < n; ++v)
      if (canon[v] != v) return false;
    return true;
  }
  std::int64_t named = 0;
  for (std::int64_t v = 0; v < n; ++v) named += canon[v] == v;
  int bits = 1;  // slots = 2^bits >= 2 named: at most half full
  while ((std::int64_t(1) << bits) < 2 * named) ++bits;
  // From the storage cache: no page faults once warm, and no memory kept aside from it.
  const std::size_t slots = std::size_t(1) << bits, mask = slots - 1;
  Storage scratch(slots * sizeof(Slot));
  Slot* const table = static_cast<Slot*>(scratch.data());
  std::fill_n(table, slots, Slot{0, -1});
  for (std::int64_t v = 0; v < n; ++v) {
    const std::int64_t c = canon[v];
    if (c != v) {  // (1): a vertex named by a smaller one, naming itself, of the same row
      if (c < 0 || c > v || canon[c] != c || !rows_equal(pos, dims, v, c)) return false;
      continue;
    }
    // (2): a self-named vertex's row, new among the self-named ones so far.
    const std::uint64_t h = row_hash(pos + v * dims, dims);
    const std::uint32_t tag = static_cast<std::uint32_t>(h);
    std::size_t s = static_cast<std::size_t>(h >> (64 - bits));
    for (; table[s].vertex >= 0; s = (s + 1) & mask)
      if (table[s].tag == tag && rows_equal(pos, dims, v, table[s].vertex)) return false;
    table[s] = {tag, static_cast<std::int32_t>(v)};
  }
  return true;
}

#define GR_INSTANTIATE(T)                                                                   \
  template std::vector<std::int32_t> weld_vertices<T>(const T*, std::int64_t, int);        \
  template bool weld_holds<T>(const T*, int, const std::vector<std::int32_t>&);
GR_INSTANTIATE(float)
GR_INSTANTIATE(double)
#undef GR_INSTANTIATE

}  // namespace gr::raster
