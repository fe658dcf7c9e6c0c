// Separable spreading and interpolation (spread.cpp): the entry points that bindings/spread.cpp binds.
#pragma once

#include <complex>

#include "sarcli_simd.hpp"

namespace sarcli {

void spread(in<int, 1> i0, in<int, 1> j0, in<float, 2> wy, in<float, 2> wx, in<std::complex<float>, 1> phase,
            in<std::complex<float>, 1> f, out<std::complex<float>, 2> grid, out<std::complex<float>, 3> scratch);
void interp(in<int, 1> i0, in<int, 1> j0, in<float, 2> wy, in<float, 2> wx, in<std::complex<float>, 1> phase,
            in<std::complex<float>, 2> grid, out<std::complex<float>, 1> o);
void kernel_weights(in<double, 1> x, int taps, in<double, 1> v, double z0, double step, out<int, 1> first,
                    out<float, 2> w);

}  // namespace sarcli
