// The Python module sarcli._native._linops: bindings of linops.hpp.
#include <nanobind/stl/optional.h>

#include "linops.hpp"

NB_MODULE(_linops, m) {
  using namespace nanobind::literals;
  namespace s = sarcli;
  m.doc() = "Streaming kernels of sarcli's operators and ADMM (float64 sums, deterministic).";
  m.def("rdot", &s::rdot, "x"_a, "y"_a, "Re <x, y> of 1-D complex128 arrays.");
  m.def("norm2", &s::norm2, "x"_a, "||x||^2.");
  m.def("rdot_diff", &s::rdot_diff, "x"_a, "a"_a, "b"_a, "Re <x, a - b>.");
  m.def("norm2_diff", &s::norm2_diff, "a"_a, "b"_a, "||a - b||^2.");
  m.def("rdot_diff2", &s::rdot_diff2, "a"_a, "b"_a, "c"_a, "d"_a, "Re <a - b, c - d>.");
  m.def("add_twice_diff", &s::add_twice_diff, "a"_a, "b"_a, "v"_a.noconvert(),
        "v <- 2 (a - b) + v in place; returns ||v||^2.");
  m.def("step_dots", &s::step_dots, "f"_a, "f_old"_a, "gf"_a, "gf_old"_a, "atb"_a,
        "(||f||^2, ||f - f_old||^2, Re <f - f_old, gf - gf_old>, Re <f, gf>, Re <f, atb>).");
  m.def("axpy", &s::axpy, "x"_a, "a"_a, "y"_a, "out"_a.noconvert(), "out = x - a y.");
  m.def("shrink_update", &s::shrink_update, "tf"_a, "sigma"_a, "beta"_a, "threshold"_a,
        "g"_a.noconvert(), "sigma_out"_a.noconvert(), "w"_a.noconvert() = nanobind::none(),
        "Grouped shrinkage and multiplier update of ADMM over arrays (K, n); returns sum |tf|.");
  m.def("diff2d_forward", &s::diff2d_forward, "x"_a, "d"_a.none(), "out"_a.noconvert(),
        "Periodic first differences of d x (rows, then columns) into out (2, ny, nx).");
  m.def("diff2d_adjoint", &s::diff2d_adjoint, "y"_a, "d"_a.none(), "out"_a.noconvert(),
        "conj(d) times the adjoint of diff2d_forward, into out (ny, nx).");
}
