// The exact matched filter's spherical-wave sum (direct.cpp): the entry points that
// bindings/direct.cpp binds.
#pragma once

#include <complex>
#include <utility>

#include "sarcli_simd.hpp"

namespace sarcli {

void accumulate_spherical(out<std::complex<double>, 1> out, in<double, 2> dr, in<double, 2> k4,
                          in<std::complex<double>, 2> wd);
std::pair<nb::ndarray<nb::numpy, double, nb::ndim<1>>, nb::ndarray<nb::numpy, double, nb::ndim<1>>>
sin_cos_array(in<double, 1> x);

}  // namespace sarcli
