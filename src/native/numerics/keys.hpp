// Keys' cubic convolution weights (a = −1/2) and the cubic Lagrange weights: the one evaluation of
// every family that interpolates with them (backprojection and its terrain kernels, ffbp).
// Self-contained (no nanobind).
#pragma once

#include <cstddef>

#include "numerics/inline.hpp"

namespace sarcli {
namespace interp {

// The weights of the samples at offsets −1, 0, 1, 2 from a fraction t in [0, 1), in T, into
// w[0], w[stride], w[2 stride], w[3 stride]:
//   w(d) = (3/2 |d| − 5/2) d² + 1 for |d| <= 1,  ((5/2 − 1/2 |d|) |d| − 4) |d| + 2 for 1 < |d| < 2,
// as polynomials in t (Horner, eleven operations where the forms in |d| take fifteen):
//   w0 = t (t (1 − t/2) − 1/2),  w1 = t² (3/2 t − 5/2) + 1,  w2 = t (t (2 − 3/2 t) + 1/2),
//   w3 = t² (t/2 − 1/2),
// Called in a vectorised loop over fractions (`#pragma omp simd`, the weights of fraction i at
// w + i, stride the row length) in every family: the compiler fuses multiplies and adds alike
// there, and so gives the same bits; a scalar evaluation may fuse them otherwise.
template <typename T>
SARCLI_INLINE void keys(T t, T* w, std::size_t stride) {
  const T t2 = t * t;
  w[0] = t * (t * (T(1) - T(0.5) * t) - T(0.5));
  w[stride] = t2 * (T(1.5) * t - T(2.5)) + T(1);
  w[2 * stride] = t * (t * (T(2) - T(1.5) * t) + T(0.5));
  w[3 * stride] = t2 * (T(0.5) * t - T(0.5));
}

// The cubic Lagrange weights (the cubic through the samples at offsets −1, 0, 1, 2, exact for
// cubics: error O(ν⁴) in the signal's frequency ν where Keys' is O(ν³)):
//   w0 = −t (t − 1)(t − 2) / 6,  w1 = (t + 1)(t − 1)(t − 2) / 2,  w2 = −(t + 1) t (t − 2) / 2,
//   w3 = (t + 1) t (t − 1) / 6,
// in eleven operations, as Keys' (no negations): with h = −(t + 1)/2 and m = t (1 − t) / 6,
//   w0 = m (t − 2),  w1 = h (t − 2)(1 − t),  w2 = h (t − 2) t,  w3 = −(t + 1) m.
// Called as keys() is (the same note on fused operations).
template <typename T>
SARCLI_INLINE void lagrange(T t, T* w, std::size_t stride) {
  const T c = t - T(2), nb = T(1) - t, na = -T(1) - t;
  const T h = T(-0.5) * t - T(0.5);
  const T hc = h * c, m = t * nb * T(1.0 / 6.0);
  w[0] = m * c;
  w[stride] = hc * nb;
  w[2 * stride] = hc * t;
  w[3 * stride] = na * m;
}

}  // namespace interp
}  // namespace sarcli
