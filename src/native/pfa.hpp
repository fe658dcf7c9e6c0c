// The polar format algorithm's gridding loop (pfa.cpp): the entry points that bindings/pfa.cpp binds.
#pragma once

#include <complex>
#include <cstdint>
#include <string>

#include "sarcli_simd.hpp"

namespace sarcli {

void spread(out<std::complex<double>, 2> grid, in<double, 1> u, in<double, 1> v, in<std::complex<double>, 1> c,
            const std::string& kernel, int width, double beta);
void kernel_taps(in<double, 1> u, const std::string& kernel, int width, double beta, out<std::int64_t, 1> first,
                 out<double, 2> t);

}  // namespace sarcli
