// Procedural meshes for tests, examples and benchmarks: cube, UV sphere,
// icosphere, torus, plane, and a 1-to-4 subdivision. Every generator returns
// normals and uvs, winds triangles counter-clockwise seen from outside (the
// geometric normal (p1-p0)×(p2-p0) points outward), and makes closed shapes
// watertight: where vertices are duplicated for uv or normal seams, the copies
// have bit-identical positions, so welding by position gives a closed
// 2-manifold. Sizes for benchmarks:
//   icosphere(s): 20·4^s triangles (5: 20480, 6: 81920, 7: 327680, 8: 1310720)
//   uv_sphere(rings, segments): 2·segments·(rings-1)
//   torus(major, minor): 2·major·minor (any even count)
//   plane(nx, ny): 2·nx·ny;   subdivide: 4× the triangles
#pragma once

#include "raster/mesh.h"

namespace gr::raster {

// Axis-aligned cube centred at the origin with edge length `size`: 24 vertices
// (4 per face, flat normals, each face's uvs spanning [0,1]²), 12 triangles.
Mesh make_cube(float size = 2.0f);

// Sphere around the y axis: `rings` latitude bands (>= 2) and `segments`
// longitude slices (>= 3). Vertices are duplicated along the u = 0/1 seam and at
// the poles (one per slice) so uvs are continuous; u follows longitude, v runs
// from 0 at the south pole (-y) to 1 at the north pole (+y).
Mesh make_uv_sphere(int rings, int segments, float radius = 1.0f);

// Sphere from a subdivided icosahedron: fully shared vertices (10·4^s + 2),
// 20·4^s triangles, normals = positions / radius. uvs are the equirectangular
// (longitude, latitude) map; triangles that straddle the u = 0/1 seam
// interpolate across the whole texture (no seam split, to keep vertices shared).
Mesh make_icosphere(int subdivisions, float radius = 1.0f);

// Torus around the y axis: major radius R (centre of the tube), minor radius r
// (0 < r < R); `major_segments` around y and `minor_segments` around the tube
// (each >= 3). Seams are duplicated for uvs: (major+1)·(minor+1) vertices.
Mesh make_torus(int major_segments, int minor_segments, float R = 1.0f, float r = 0.25f);

// Square in the z = 0 plane facing +z, centred, side `size`, split into nx × ny
// cells (2 triangles each). u runs along +x, v along +y, both over [0, 1].
Mesh make_plane(int nx, int ny, float size = 2.0f);

// Splits every triangle into 4 through its edge midpoints; a midpoint is shared
// by the triangles on both sides of an edge (keyed by the edge's two vertex
// indices). Midpoint normals are the normalized mean of the endpoints' normals,
// uvs the mean. Triangle t becomes triangles 4t..4t+3 (three corners, then the
// centre). Positions are not projected: the shape is unchanged.
Mesh subdivide(const Mesh& mesh);

}  // namespace gr::raster
