// The cube maps' taps (raster/cube_map.cpp: cube_project, its Hessian,
// cube_texel; raster/cube_texture.cpp: compute_lod, bilinear_taps,
// sample_taps), after texture_common.glsl. The texels buffer holds face f's
// levels at f x face_texels() (levels as level_of, the levels of one face);
// uv holds the directions (3 per sample), uv_dx their dir_da (6 per sample).

// Per-sample gradients cube_texture_backward writes: d dir (3), d dir_da (6), d bias.
const int kSampleGrads = 10;

// raster/cube_map.h's kCubeFaces: (major, s_axis, t_axis) and (major_sign,
// s_sign, t_sign) of faces +X, -X, +Y, -Y, +Z, -Z.
const ivec3 kFaceAxes[6] = ivec3[6](ivec3(0, 2, 1), ivec3(0, 2, 1), ivec3(1, 0, 2), ivec3(1, 0, 2),
                                    ivec3(2, 0, 1), ivec3(2, 0, 1));
const ivec3 kFaceSigns[6] = ivec3[6](ivec3(1, -1, -1), ivec3(-1, 1, -1), ivec3(1, 1, 1), ivec3(-1, 1, -1),
                                     ivec3(1, 1, -1), ivec3(-1, -1, -1));

// Texels of one face's levels.
int face_texels() {
  ivec4 last = level_of[P.levels - 1];
  return last.z + last.x * last.y;
}

// A direction on its face (CubeProjection): face -1 for the zero vector.
struct Projection {
  int face;
  double s, t, q, sc, tc;
  double ds[3], dt[3];
};

Projection cube_project(int i) {
  Projection p;
  p.face = -1;
  p.s = 0.0, p.t = 0.0, p.q = 0.0, p.sc = 0.0, p.tc = 0.0;
  for (int k = 0; k < 3; ++k) p.ds[k] = 0.0, p.dt[k] = 0.0;
  double d[3] = double[3](double(uv[3 * i]), double(uv[3 * i + 1]), double(uv[3 * i + 2]));
  // Major axis: z if strictly the largest, else y if larger than x, else x.
  double ax = abs(d[0]), ay = abs(d[1]), az = abs(d[2]);
  int m = az > max(ax, ay) ? 2 : ay > ax ? 1 : 0;
  if (d[m] == 0.0) return p;
  p.face = 2 * m + (d[m] < 0.0 ? 1 : 0);
  ivec3 axes = kFaceAxes[p.face], signs = kFaceSigns[p.face];
  p.q = abs(d[m]);
  p.sc = double(signs.y) * d[axes.y];
  p.tc = double(signs.z) * d[axes.z];
  // s = (sc / |ma| + 1) / 2, t likewise, clamped into [0, 1] against rounding.
  precise double s = div_rn(0.5 * p.sc, p.q) + 0.5;
  precise double t = div_rn(0.5 * p.tc, p.q) + 0.5;
  p.s = min(1.0, max(0.0, s));
  p.t = min(1.0, max(0.0, t));
  // Quotient rule: ds = (dsc q - sc dq) / (2 q^2).
  double h = div_rn(0.5, p.q);
  double h2 = div_rn(h, p.q);
  precise double dsm = double(-signs.x) * p.sc * h2;
  precise double dtm = double(-signs.x) * p.tc * h2;
  p.ds[axes.y] = double(signs.y) * h;
  p.ds[m] = dsm;
  p.dt[axes.z] = double(signs.z) * h;
  p.dt[m] = dtm;
  return p;
}

// hs = (d^2 s / d dir^2) vs and ht = (d^2 t / d dir^2) vt (cube_project_hessian_times).
void hessian_times(Projection p, double vs[3], double vt[3], out double hs[3], out double ht[3]) {
  for (int k = 0; k < 3; ++k) hs[k] = 0.0, ht[k] = 0.0;
  ivec3 axes = kFaceAxes[p.face], signs = kFaceSigns[p.face];
  int m = axes.x;
  precise double q2 = p.q * p.q;
  precise double q3 = q2 * p.q;
  double cs = div_rn(double(-signs.y * signs.x) * 0.5, q2);
  double ct = div_rn(double(-signs.z * signs.x) * 0.5, q2);
  precise double hsa = cs * vs[m];
  precise double hsm = cs * vs[axes.y] + div_rn(p.sc, q3) * vs[m];
  precise double hta = ct * vt[m];
  precise double htm = ct * vt[axes.z] + div_rn(p.tc, q3) * vt[m];
  hs[axes.y] = hsa;
  hs[m] = hsm;
  ht[axes.z] = hta;
  ht[m] = htm;
}

// Texel (col, row) of `face`, col or row one step off the face: the
// neighbour's texel across that edge; off both (a cube corner): face -1
// (cube_texel, on the texel centre's point scaled by S, in exact integers).
ivec3 cube_texel(int face, int col, int row, int S) {
  bool off_col = col < 0 || col >= S, off_row = row < 0 || row >= S;
  if (!off_col && !off_row) return ivec3(face, col, row);
  if (off_col && off_row) return ivec3(-1, 0, 0);
  ivec3 axes = kFaceAxes[face], signs = kFaceSigns[face];
  int P3[3];
  P3[axes.x] = signs.x * S;
  P3[axes.y] = signs.y * (2 * col + 1 - S);
  P3[axes.z] = signs.z * (2 * row + 1 - S);
  // Fold the overhang over the edge onto the neighbour.
  int off = off_col ? axes.y : axes.z;
  int overhang = abs(P3[off]) - S;
  P3[off] = P3[off] < 0 ? -S : S;
  P3[axes.x] = signs.x * (S - overhang);
  int nf = 2 * off + (P3[off] < 0 ? 1 : 0);
  ivec3 n_axes = kFaceAxes[nf], n_signs = kFaceSigns[nf];
  int sc = n_signs.y * P3[n_axes.y], tc = n_signs.z * P3[n_axes.z];
  return ivec3(nf, (sc + S - 1) / 2, (tc + S - 1) / 2);
}

// The LOD and what its derivative needs (Lod in raster/cube_texture.cpp).
struct Lod {
  double value;
  bool free, footprint;
  double dX[3], dY[3];
  double sX, sY, tX, tY, A, B, C, r, M;
};

Lod compute_lod(int i, Projection pr) {
  Lod l;
  l.footprint = (P.flags & kHasDerivatives) != 0;
  double lod_bias = bias_of(i);
  l.sX = 0.0, l.sY = 0.0, l.tX = 0.0, l.tY = 0.0, l.A = 0.0, l.B = 0.0, l.C = 0.0, l.r = 0.0, l.M = 0.0;
  for (int k = 0; k < 3; ++k) l.dX[k] = 0.0, l.dY[k] = 0.0;
  if (!l.footprint) {  // the bias alone
    double last = double(P.levels - 1);
    l.free = lod_bias > 0.0 && lod_bias < last;
    l.value = lod_bias > 0.0 ? min(lod_bias, last) : 0.0;
    return l;
  }
  // dir_da = (dx/dX, dx/dY, dy/dX, dy/dY, dz/dX, dz/dY).
  for (int k = 0; k < 3; ++k) l.dX[k] = double(uv_dx[6 * i + 2 * k]), l.dY[k] = double(uv_dx[6 * i + 2 * k + 1]);
  // Face texels per pixel: sX = S ds/d(dir) . d(dir)/dX.
  double size = double(level_of[0].y);
  precise double sX = size * ((pr.ds[0] * l.dX[0] + pr.ds[1] * l.dX[1]) + pr.ds[2] * l.dX[2]);
  precise double sY = size * ((pr.ds[0] * l.dY[0] + pr.ds[1] * l.dY[1]) + pr.ds[2] * l.dY[2]);
  precise double tX = size * ((pr.dt[0] * l.dX[0] + pr.dt[1] * l.dX[1]) + pr.dt[2] * l.dX[2]);
  precise double tY = size * ((pr.dt[0] * l.dY[0] + pr.dt[1] * l.dY[1]) + pr.dt[2] * l.dY[2]);
  // Major axis of the footprint: M = (A + B)/2 + sqrt((A - B)^2/4 + C^2).
  precise double A = sX * sX + tX * tX;
  precise double B = sY * sY + tY * tY;
  precise double C = sX * sY + tX * tY;
  precise double r = sqrt(0.25 * (A - B) * (A - B) + C * C);
  precise double M = 0.5 * (A + B) + r;
  l.sX = sX, l.sY = sY, l.tX = tX, l.tY = tY, l.A = A, l.B = B, l.C = C, l.r = r, l.M = M;
  clamp_lod(M, lod_bias, l.value, l.free);
  return l;
}

// Bilinear taps of `level` on `face` at (s, t), scaled by `scale`; lod_sign:
// the sign of d(level weight)/d lod. Taps off the face read the neighbour's
// texel; at a cube corner the missing 4th tap's weight goes a third to each
// of the other 3 (bilinear_taps).
void bilinear_taps(int level, int face, double s, double t, double scale, inout Taps taps, double lod_sign,
                   bool derivatives) {
  ivec4 lv = level_of[level];
  int n = lv.y;
  int total = face_texels();
  precise double x = s * double(n) - 0.5;
  precise double y = t * double(n) - 0.5;
  double x0 = floor(x), y0 = floor(y);
  precise double fx = x - x0;
  precise double fy = y - y0;
  precise double wx[2] = double[2](1.0 - fx, fx);
  precise double wy[2] = double[2](1.0 - fy, fy);
  double dw[2] = double[2](-double(n), double(n));
  int first = taps.n;
  double miss_w = 0.0, miss_ds = 0.0, miss_dt = 0.0, miss_dlod = 0.0;
  bool missing = false;
  for (int b = 0; b < 2; ++b)
    for (int a = 0; a < 2; ++a) {
      ivec3 tx = cube_texel(face, int(x0) + a, int(y0) + b, n);
      precise double w = scale * wx[a] * wy[b];
      precise double ds = scale * dw[a] * wy[b];
      precise double dt = scale * wx[a] * dw[b];
      precise double dl = lod_sign * wx[a] * wy[b];
      if (!derivatives) ds = 0.0, dt = 0.0, dl = 0.0;
      if (tx.x < 0) {
        missing = true;
        miss_w = w, miss_ds = ds, miss_dt = dt, miss_dlod = dl;
        continue;
      }
      int k = taps.n++;
      taps.index[k] = tx.x * total + lv.z + tx.z * n + tx.y;
      taps.w[k] = w;
      taps.dw_du[k] = ds;
      taps.dw_dv[k] = dt;
      taps.dw_dlod[k] = dl;
    }
  if (!missing) return;
  double third_w = div_rn(miss_w, 3.0), third_ds = div_rn(miss_ds, 3.0);
  double third_dt = div_rn(miss_dt, 3.0), third_dlod = div_rn(miss_dlod, 3.0);
  for (int k = first; k < taps.n; ++k) {
    precise double w = taps.w[k] + third_w;
    precise double ds = taps.dw_du[k] + third_ds;
    precise double dt = taps.dw_dv[k] + third_dt;
    precise double dl = taps.dw_dlod[k] + third_dlod;
    taps.w[k] = w, taps.dw_du[k] = ds, taps.dw_dv[k] = dt, taps.dw_dlod[k] = dl;
  }
}

// Taps of sample s (sample_taps), with its projection and LOD; none for the
// zero direction. derivatives: trilinear keeps level l0 + 1 at f = 0 too when
// the LOD is free (its taps give dw/dlod).
Taps cube_taps(int s, bool derivatives, out Projection pr, out Lod lod) {
  Taps t;
  t.n = 0;
  t.lod_free = false;
  pr = cube_project(s);
  lod.value = 0.0, lod.free = false, lod.footprint = false;
  if (pr.face < 0) return t;
  int L = P.levels;
  if (P.filter_mode == kTrilinear || P.filter_mode == kLinearMipmapNearest) lod = compute_lod(s, pr);
  if (P.filter_mode == kNearest) {
    // The texel containing (s S, t S), kept inside the face at s = 1 or t = 1.
    int n = level_of[0].y;
    precise double cs = pr.s * double(n);
    precise double ct = pr.t * double(n);
    int col = min(n - 1, int(cs)), row = min(n - 1, int(ct));
    t.n = 1;
    t.index[0] = pr.face * face_texels() + row * n + col;
    t.w[0] = 1.0;
    t.dw_du[0] = 0.0, t.dw_dv[0] = 0.0, t.dw_dlod[0] = 0.0;
  } else if (P.filter_mode == kBilinear) {
    bilinear_taps(0, pr.face, pr.s, pr.t, 1.0, t, 0.0, derivatives);
  } else if (P.filter_mode == kLinearMipmapNearest) {
    bilinear_taps(min(int(lod.value), L - 1), pr.face, pr.s, pr.t, 1.0, t, 0.0, derivatives);
  } else {
    int l0 = min(int(lod.value), L - 1);
    precise double f = l0 == L - 1 ? 0.0 : lod.value - double(l0);
    bilinear_taps(l0, pr.face, pr.s, pr.t, 1.0 - f, t, -1.0, derivatives);
    if (f > 0.0 || (derivatives && lod.free)) bilinear_taps(l0 + 1, pr.face, pr.s, pr.t, f, t, 1.0, derivatives);
    t.lod_free = lod.free;
  }
  return t;
}

Taps sample_taps(int s, bool derivatives) {
  Projection pr;
  Lod lod;
  return cube_taps(s, derivatives, pr, lod);
}
