// Streaming kernels of the operators and ADMM (linops.cpp): the entry points that
// bindings/linops.cpp binds.
#pragma once

#include <complex>
#include <optional>

#include "sarcli_simd.hpp"

namespace sarcli {

double rdot(in<std::complex<double>, 1> x, in<std::complex<double>, 1> y);
double norm2(in<std::complex<double>, 1> x);
double rdot_diff(in<std::complex<double>, 1> x, in<std::complex<double>, 1> a, in<std::complex<double>, 1> b);
double norm2_diff(in<std::complex<double>, 1> a, in<std::complex<double>, 1> b);
double rdot_diff2(in<std::complex<double>, 1> a, in<std::complex<double>, 1> b, in<std::complex<double>, 1> c,
                  in<std::complex<double>, 1> d);
double add_twice_diff(in<std::complex<double>, 1> a, in<std::complex<double>, 1> b, out<std::complex<double>, 1> v);
nb::tuple step_dots(in<std::complex<double>, 1> f, in<std::complex<double>, 1> f_old, in<std::complex<double>, 1> gf,
                    in<std::complex<double>, 1> gf_old, in<std::complex<double>, 1> atb);
void axpy(in<std::complex<double>, 1> x, double a, in<std::complex<double>, 1> y, out<std::complex<double>, 1> o);
double shrink_update(in<std::complex<double>, 2> tf, in<std::complex<double>, 2> sigma, double beta, double thr,
                     out<std::complex<double>, 2> g, out<std::complex<double>, 2> sig_out,
                     std::optional<out<std::complex<double>, 2>> w);
void diff2d_forward(in<std::complex<double>, 2> x, std::optional<in<std::complex<double>, 2>> d,
                    out<std::complex<double>, 3> o);
void diff2d_adjoint(in<std::complex<double>, 3> y, std::optional<in<std::complex<double>, 2>> d,
                    out<std::complex<double>, 2> o);

}  // namespace sarcli
