// The adjoint of every texture lookup, after its taps' include
// (texture_taps.glsl or cube_taps.glsl: sample_taps, kSampleGrads). Per
// sample with a non-zero incoming gradient g: pass 0 writes the sample's own
// gradients (sample_gradients, defined by the shader after this include) and
// notes the largest texel contribution; pass 1 adds every contribution w_t g
// to its texel value in fixed point (fixed_point.glsl), so the sums do not
// depend on the order of arrival.
#include "fixed_point.glsl"

layout(std430, binding = 6) readonly buffer GradOutBuf { float grad_out[]; };
// Fixed-point sums: every level's texel values (level l from level_of[l].z * C).
layout(std430, binding = 7) buffer SumBuf { int64_t sums[]; };
// Per sample: kSampleGrads gradients (the taps' include lists them).
layout(std430, binding = 9) writeonly buffer SampleGradBuf { float sample_grads[]; };

// g . texel over the channels, in double in channel order (dot_channels).
double dot_texel(int s, int index) {
  int C = P.channels;
  precise double d = 0.0;
  for (int c = 0; c < C; ++c) d += double(grad_out[s * C + c]) * double(texels[index * C + c]);
  return d;
}

// Writes sample s's kSampleGrads gradients from its taps (pass 0).
void sample_gradients(int s, Taps t);

// w_t as the CPU kernel files it for the texel sums (the shader's own rounding).
double filed_weight(double w);

void lookup(int s, int shift) {
  int C = P.channels;
  bool live = false;
  for (int c = 0; c < C && !live; ++c) live = grad_out[s * C + c] != 0.0;
  if (!live) {
    if (P.pass == 0)
      for (int i = 0; i < kSampleGrads; ++i) sample_grads[kSampleGrads * s + i] = 0.0;
    return;
  }
  Taps t = sample_taps(s, true);
  if (P.pass == 0) sample_gradients(s, t);
  if ((P.flags & kTexelGrads) == 0) return;
  // dL/d texel_t += w_t g.
  for (int k = 0; k < t.n; ++k) {
    double w = filed_weight(t.w[k]);
    for (int c = 0; c < C; ++c) {
      precise double x = w * double(grad_out[s * C + c]);
      if (P.pass == 0)
        note_magnitude(0, x);
      else if (x != 0.0)
        atomicAdd(sums[t.index[k] * C + c], to_fixed(x, shift));
    }
  }
}

void main() {
  int s = linear_id();
  if (s < P.num_samples) lookup(s, P.pass == 0 ? 0 : fixed_point_shift(0, P.contributions));
  if (P.pass == 0) publish_magnitudes();
}
