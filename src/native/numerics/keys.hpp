// Keys' cubic convolution weights (a = −1/2): the one evaluation of every family that interpolates
// with it (backprojection and its terrain kernels, ffbp). Self-contained (no nanobind).
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

}  // namespace interp
}  // namespace sarcli
