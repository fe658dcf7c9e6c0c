// The Python module sarcli._native._pfa: bindings of pfa.hpp.
#include <nanobind/stl/string.h>

#include "pfa.hpp"

NB_MODULE(_pfa, m) {
  using namespace nanobind::literals;
  m.doc() = "The polar format algorithm's gridding (spreading) loop.";
  m.def("spread", &sarcli::spread, "grid"_a.noconvert(), "u"_a, "v"_a, "c"_a, "kernel"_a, "width"_a,
        "beta"_a,
        "grid[fy + b, fx + a] += c[s] ty[b] tx[a] with the kernel ('kaiser' of shape beta, or "
        "'linear') of width cells centred at the fractional grid indices (u[s], v[s]); grid "
        "(nky, nkx) complex128.");
  m.def("kernel_taps", &sarcli::kernel_taps, "u"_a, "kernel"_a, "width"_a, "beta"_a,
        "first"_a.noconvert(), "taps"_a.noconvert(),
        "First grid index and taps of the kernel centred at each fractional index u.");
}
