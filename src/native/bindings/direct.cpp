// The Python module sarcli._native._direct: bindings of direct.hpp.
#include <nanobind/stl/pair.h>

#include "direct.hpp"

NB_MODULE(_direct, m) {
  using namespace nanobind::literals;
  m.doc() = "The exact matched filter's spherical-wave sum (float64 phases).";
  m.def("accumulate_spherical", &sarcli::accumulate_spherical, "out"_a.noconvert(), "dr"_a, "k4"_a,
        "wd"_a,
        "out[n] += sum_p sum_j wd[p, j] exp(i k4[p, j] dr[p, n]); out (n_pix,), dr (P, n_pix), "
        "k4 (P, M) float64, wd (P, M) complex128.");
  m.def("sin_cos", &sarcli::sin_cos_array, "x"_a,
        "(sin x, cos x) by the kernel's own polynomials (valid for |x| < 1e8).");
}
