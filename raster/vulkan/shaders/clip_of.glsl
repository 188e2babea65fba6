// Clip coordinates (x, y, z, w) of vertex i in double (exact from float) as
// the rasterizer saw them: with y_up, y negated (exact), so row 0 is the
// bottom row. Needs the `clip` buffer (binding 0) and P.y_up, P.width, P.height.
dvec4 clip_of(int i) {
  dvec4 c = dvec4(clip[4 * i], clip[4 * i + 1], clip[4 * i + 2], clip[4 * i + 3]);
  if (P.y_up != 0) c.y = -c.y;
  return c;
}

// Homogeneous screen vertex V = (W/2 (x + w), H/2 (w - y), w).
dvec3 homogeneous(int i) {
  dvec4 c = clip_of(i);
  precise double hx = (0.5 * double(P.width)) * (c.x + c.w);
  precise double hy = (0.5 * double(P.height)) * (c.w - c.y);
  return dvec3(hx, hy, c.w);
}
