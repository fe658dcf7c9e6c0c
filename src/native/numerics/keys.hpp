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
// cubics: error O(ν⁴) in the signal's frequency ν where Keys' is O(ν³)), with a = t + 1, b = t − 1,
// c = t − 2:
//   w0 = −t b c / 6,  w1 = a b c / 2,  w2 = −a t c / 2,  w3 = a t b / 6,
// in ten operations: the products t b and a c are shared, w1 = (a c) b / 2, w2 = −(a c) t / 2,
// w0 = −(t b) c / 6, w3 = (t b) a / 6. Called as keys() is (the same note on fused operations).
template <typename T>
SARCLI_INLINE void lagrange(T t, T* w, std::size_t stride) {
  const T a = t + T(1), b = t - T(1), c = t - T(2);
  const T tb = t * b, ac = a * c;
  const T tb6 = tb * T(1.0 / 6.0), ac2 = ac * T(0.5);
  w[0] = -tb6 * c;
  w[stride] = ac2 * b;
  w[2 * stride] = -ac2 * t;
  w[3 * stride] = tb6 * a;
}

}  // namespace interp
}  // namespace sarcli
