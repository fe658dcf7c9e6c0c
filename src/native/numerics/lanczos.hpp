// Lanczos-3 weights: the one evaluation of every family that interpolates with it (backprojection
// and its terrain kernels, ffbp), float32 with the carrier's sine (numerics/sincos.hpp).
// Self-contained (no nanobind).
#pragma once

#include <cmath>

#include "numerics/inline.hpp"
#include "numerics/sincos.hpp"

namespace sarcli {
namespace interp {

// sin(π d / 3) for |d| < 3 by the float32 carrier (its argument stays within (−π, π)).
SARCLI_INLINE float sin_third(float d) {
  float c, s;
  carrier::cos_sin_small_f32(static_cast<double>(d) * (6.283185307179586 / 6.0), c, s);
  return s;
}

// The weights sinc(d) sinc(d/3) of the samples at offsets −2 .. 3 from a fraction t in [0, 1)
// (d = t + 2 − k for tap k), normalised to sum to one; sin(π d) = ±sin(π t) from one carrier.
SARCLI_INLINE void lanczos3(float t, float* w) {
  float c, s;
  carrier::cos_sin_small_f32(static_cast<double>(t) * (6.283185307179586 / 2.0), c, s);  // sin(π t)
  const float spt = s;
  float tot = 0.0f;
  for (int k = 0; k < 6; ++k) {
    const float d = t + static_cast<float>(2 - k);
    const float sgn = (k & 1) ? -1.0f : 1.0f;  // sin(π (t + 2 − k)) = ±sin(π t)
    const float num = 3.0f * sgn * spt * sin_third(d);
    const float den = 9.869604401089358f * d * d;
    const float v = std::fabs(d) < 1e-6f ? 1.0f : (std::fabs(d) >= 3.0f ? 0.0f : num / den);
    w[k] = v;
    tot += v;
  }
  const float inv = 1.0f / tot;
  for (int k = 0; k < 6; ++k) w[k] *= inv;
}

}  // namespace interp
}  // namespace sarcli
