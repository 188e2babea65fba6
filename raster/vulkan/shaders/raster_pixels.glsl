// The depth buffer passes over one triangle's pixels, shared by the per-triangle
// (small boxes) and per-workgroup (large boxes) shaders. Pass 0 keeps the
// nearest depth per pixel (a 64-bit atomic min of an order-preserving key);
// pass 1 keeps the smallest triangle index among those at exactly that depth.
// Both are minima, so the result does not depend on the order in which
// triangles or pixels are visited: the CPU's (depth, id) rule, bit for bit.
#extension GL_EXT_shader_atomic_int64 : require

layout(std430, binding = 3) buffer KeyBuf { uint64_t keys[]; };
layout(std430, binding = 4) buffer IdBuf { int ids[]; };
// The triangles with large boxes, listed by raster_small.comp's pass 0: entry e
// = (triangle, first chunk), chunks of kChunk pixels of the box numbered over
// all entries in entry order. large_counter: entries << 32 | chunks, advanced
// by one 64-bit atomic add per triangle, so each entry's first chunk is the
// chunks before it and the entries ascend by first chunk.
const int kChunk = 64;
layout(std430, binding = 5) buffer LargeBuf {
  uint64_t large_counter;
  uvec2 large[];
};

// Depth peeling (flags bit 1): the previous layer's key per pixel (key =
// depth_key of its depth, id 1-based, 0 where it was background). A fragment
// counts only when its (depth, id) is strictly greater, and nowhere behind a
// background: the CPU's rule (raster/detail/rasterize_scan.cpp).
struct FloorKey {
  uint64_t key;
  int id;
  int pad;
};
layout(std430, binding = 9) readonly buffer FloorBuf { FloorKey floors[]; };

bool above_floor(int p, uint64_t key, int t) {
  if ((P.flags & 2) == 0) return true;
  FloorKey f = floors[p];
  return f.id != 0 && (key > f.key || (key == f.key && t + 1 > f.id));
}

void raster_pixel(Setup s, int t, int x, int y) {
  double z, u, v;
  if (!shade_pixel(s, x, y, z, u, v)) return;
  int p = y * P.width + x;
  uint64_t key = depth_key(z);
  if (!above_floor(p, key, t)) return;
  if (P.pass == 0)
    atomicMin(keys[p], key);
  else if (keys[p] == key)
    atomicMin(ids[p], t);
}
