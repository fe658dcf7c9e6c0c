// Keys' cubic convolution weights (a = −1/2): the one evaluation of every family that interpolates
// with it (backprojection and its terrain kernels, ffbp). Self-contained (no nanobind).
#pragma once

#include <cstddef>

#include "numerics/inline.hpp"

namespace sarcli {
namespace interp {

// The weights of the samples at offsets −1, 0, 1, 2 from a fraction t in [0, 1), in T, into
// w[0], w[stride], w[2 stride], w[3 stride]:
//   w(d) = (3/2 |d| − 5/2) d² + 1 for |d| <= 1,  ((5/2 − 1/2 |d|) |d| − 4) |d| + 2 for 1 < |d| < 2.
// Called in a vectorised loop over fractions (`#pragma omp simd`, the weights of fraction i at
// w + i, stride the row length) in every family: the compiler fuses multiplies and adds alike
// there, and so gives the same bits; a scalar evaluation may fuse them otherwise.
template <typename T>
SARCLI_INLINE void keys(T t, T* w, std::size_t stride) {
  const T d0 = t + T(1), d2 = T(1) - t, d3 = T(2) - t;
  w[0] = ((T(2.5) - T(0.5) * d0) * d0 - T(4)) * d0 + T(2);
  w[stride] = (T(1.5) * t - T(2.5)) * t * t + T(1);
  w[2 * stride] = (T(1.5) * d2 - T(2.5)) * d2 * d2 + T(1);
  w[3 * stride] = ((T(2.5) - T(0.5) * d3) * d3 - T(4)) * d3 + T(2);
}

}  // namespace interp
}  // namespace sarcli
