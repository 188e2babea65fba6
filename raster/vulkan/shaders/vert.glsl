// Per vertex, written by project.comp: screen x, y, z_ndc (valid when in
// front) and flags: bit 0 in front of the near plane, bits 1..7 the frustum
// outcode. 32 bytes (Frame's kVerts buffer).
struct Vert {
  double sx;
  double sy;
  double zn;
  uint flags;
  uint pad;
};
