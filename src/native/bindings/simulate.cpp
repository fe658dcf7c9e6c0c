// The Python module sarcli._native._simulate: bindings of simulate.hpp.

#include "simulate.hpp"

NB_MODULE(_simulate, m) {
  using namespace nanobind::literals;
  m.doc() = "sarcli's simulator loops (exact spherical-model sums).";
  m.def("spherical_sum", &sarcli::spherical_sum, "freq"_a, "antenna"_a, "offset"_a, "points_xy"_a,
        "amp"_a, "out"_a,
        "out[p, j] += sum_s amp[s] exp(-i 4 pi f[p, j] (|a_p - x_s| - r0_p) / c), float64; "
        "offset[p] = |a_p| - r0_p.");
}
