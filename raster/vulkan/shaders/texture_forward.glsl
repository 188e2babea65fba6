// The forward of every texture lookup, after its taps' include (texture_taps.glsl
// or cube_taps.glsl, which define sample_taps): per sample, out = sum_t w_t
// texel_t over its taps, summed in double in tap order and rounded once
// (texture_forward in raster/texture.cpp, cube_texture_forward in raster/cube_texture.cpp).

layout(std430, binding = 6) writeonly buffer OutBuf { float out_values[]; };

void lookup(int s) {
  Taps t = sample_taps(s, false);
  int C = P.channels;
  for (int c = 0; c < C; ++c) {
    precise double a = 0.0;
    for (int k = 0; k < t.n; ++k) a += t.w[k] * double(texels[t.index[k] * C + c]);
    // The CPU's sum starts at +0, so it is never -0 (a driver may drop 0 + x's sign).
    out_values[s * C + c] = a == 0.0 ? 0.0 : float(a);
  }
}

void main() {
  int s = linear_id();
  if (s < P.num_samples) lookup(s);
}
