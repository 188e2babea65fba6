// Cube-map geometry (no tape, no texels): which face a 3D direction hits and
// where, the derivatives of that projection, and where a texel one step off a
// face's edge lives on the neighbouring face (docs/cube_maps.md).
//
// Faces and orientation follow OpenGL ("Cube Map Texture Selection"; also
// nvdiffrast): faces 0..5 = +X, -X, +Y, -Y, +Z, -Z. The major axis is the
// component of largest magnitude (ties: z only if strictly larger than x and
// y, then y if strictly larger than x, else x, as nvdiffrast), and with
// ma = that component:
//   face  sc    tc    ma
//   +X    -z    -y    x
//   -X    +z    -y    x
//   +Y    +x    +z    y
//   -Y    +x    -z    y
//   +Z    +x    -y    z
//   -Z    -x    -y    z
// s = (sc / |ma| + 1) / 2, t = (tc / |ma| + 1) / 2, both in [0, 1]; on a face
// of S x S texels, column = s S, row = t S (texel (col, row) has its centre at
// s = (col + 0.5) / S, t = (row + 0.5) / S).
#pragma once

namespace gr::raster {

// One row of the table above: sc = s_sign * dir[s_axis], tc = t_sign *
// dir[t_axis], ma = dir[major] with sign major_sign on this face.
struct CubeFace {
  int major, s_axis, t_axis;
  int major_sign, s_sign, t_sign;
};
inline constexpr CubeFace kCubeFaces[6] = {
    {0, 2, 1, +1, -1, -1},  // +X
    {0, 2, 1, -1, +1, -1},  // -X
    {1, 0, 2, +1, +1, +1},  // +Y
    {1, 0, 2, -1, +1, -1},  // -Y
    {2, 0, 1, +1, +1, -1},  // +Z
    {2, 0, 1, -1, -1, -1},  // -Z
};

// A direction projected onto its face, with the first derivatives of (s, t).
struct CubeProjection {
  int face = -1;        // -1: the zero vector (no face)
  double s = 0, t = 0;  // in [0, 1] (clamped against rounding)
  double q = 0;         // |ma|
  double sc = 0, tc = 0;
  // ds/d(dir), dt/d(dir): with s = sc / (2q) + 1/2,
  //   ds/d dir[s_axis] = s_sign / (2q),  ds/d dir[major] = -major_sign sc / (2 q^2),
  // likewise t; zero along the third axis.
  double ds[3] = {0, 0, 0}, dt[3] = {0, 0, 0};
};

CubeProjection cube_project(double x, double y, double z);

// Second derivatives: hs_v = (d^2 s / d dir^2) v and ht_v likewise, for the
// LOD's dependence on the direction (d(ds/dX)/d dir = (d^2 s/d dir^2) d dir/dX).
// Nonzero entries of d^2 s / d dir^2 (symmetric): [s_axis][major] =
// -s_sign major_sign / (2 q^2), [major][major] = sc / q^3.
void cube_project_hessian_times(const CubeProjection& p, const double v[3], double hs_v[3], double ht_v[3]);

// A texel of a face of size x size; face -1 marks the missing 4th texel at a
// cube corner.
struct CubeTexel {
  int face = -1, col = 0, row = 0;
};

// Texel (col, row) of `face`, where col and row may each be one step off the
// face (-1 or size): a texel off one edge is the neighbouring face's texel
// next to that edge (the overhang folded over the cube's edge); off two edges
// at once (a corner) no texel exists and face = -1. In range: itself.
CubeTexel cube_texel(int face, int col, int row, int size);

}  // namespace gr::raster
