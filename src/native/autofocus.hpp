// Autofocus kernels (autofocus.cpp): the entry points that bindings/autofocus.cpp binds.
#pragma once

#include <complex>
#include <optional>

#include "sarcli_simd.hpp"

namespace sarcli {

nb::tuple entropy_sums(in<std::complex<float>, 2> stack, in<std::complex<float>, 1> e, double alpha,
                       std::optional<out<std::complex<double>, 1>> x, std::optional<out<std::complex<double>, 1>> y);
void point_signals(in<std::complex<double>, 2> d, in<double, 2> kw, in<double, 2> dr, out<std::complex<double>, 2> z);

}  // namespace sarcli
