// The simulator's loops (simulate.cpp): the entry points that bindings/simulate.cpp binds.
#pragma once

#include <complex>

#include "sarcli_simd.hpp"

namespace sarcli {

void spherical_sum(in<double, 2> freq, in<double, 2> antenna, in<double, 1> offset, in<double, 2> points_xy,
                   in<std::complex<double>, 1> amp, out<std::complex<double>, 2> result);

}  // namespace sarcli
