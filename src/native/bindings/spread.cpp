// The Python module sarcli._native._spread: bindings of spread.hpp.

#include "spread.hpp"

NB_MODULE(_spread, m) {
  using namespace nanobind::literals;
  namespace s = sarcli;
  m.doc() = "Separable spreading / interpolation with precomputed weights (complex64).";
  m.def("spread", &s::spread, "i0"_a, "j0"_a, "wy"_a, "wx"_a, "phase"_a, "f"_a, "grid"_a.noconvert(),
        "scratch"_a.noconvert(),
        "grid[i0+a, j0+b] = sum over points of phase f wy[a] wx[b] (grid overwritten); scratch: "
        "(threads - 1, n0, n1) grids for the other threads' shares.");
  m.def("kernel_weights", &s::kernel_weights, "x"_a, "taps"_a, "v"_a, "z0"_a, "step"_a, "first"_a.noconvert(),
        "w"_a.noconvert(), "first = ceil(x - taps/2); w[n, j] = table v (z = z0 + k step) at first + j - x, linearly.");
  m.def("interp", &s::interp, "i0"_a, "j0"_a, "wy"_a, "wx"_a, "phase"_a, "grid"_a, "out"_a.noconvert(),
        "out[n] = conj(phase[n]) sum_ab grid[i0+a, j0+b] wy[n, a] wx[n, b]: the adjoint of spread.");
}
