// The Python module sarcli._native._autofocus: bindings of autofocus.hpp.
#include <nanobind/stl/optional.h>
#include <nanobind/stl/tuple.h>

#include "autofocus.hpp"

NB_MODULE(_autofocus, m) {
  using namespace nanobind::literals;
  namespace s = sarcli;
  m.doc() = "Entropy sums of a sub-aperture image stack (fused with its gradient's); pulses' matched filters at points.";
  m.def("entropy_sums", &s::entropy_sums, "stack"_a, "e"_a, "alpha"_a, "x"_a.noconvert().none(),
        "y"_a.noconvert().none(),
        "(E, T) of f = e @ stack: E = Σ|f|², T = Σ I ln I (alpha = 1) or Σ I^alpha; with x, y "
        "(complex128, one per image) also X_b = Σ_s stack[b,s] conj(f_s) a_s (a = ln I or "
        "I^(alpha-1), 0 where I = 0) and Y_b = Σ_s stack[b,s] conj(f_s).");
  m.def("point_signals", &s::point_signals, "d"_a, "kw"_a, "dr"_a, "z"_a.noconvert(),
        "z[p, k] = (1/M) sum_j d[p, j] exp(i kw[p, j] dr[p, k]) (pulse p's matched filter at point k).");
}
