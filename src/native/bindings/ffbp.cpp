// The Python module sarcli._native._ffbp: bindings of ffbp.hpp.
#include "ffbp.hpp"
#include "numerics/kinds.hpp"

NB_MODULE(_ffbp, m) {
  using namespace nanobind::literals;
  namespace s = sarcli;
  namespace nb = nanobind;
  m.doc() = "Fast factorised backprojection kernels (sarcli.formers.ffbp): stage 0, merges, final stage, "
            "tone weights.";
  // the tables' rows by name (sarcli._native.layout names the same rows)
  nb::dict frame_rows, pulse_rows;
  const char* frame_names[] = {"cx", "cy", "cn", "rho0", "e0x", "e0y", "cz", "q0", "u0", "du"};
  for (int r = 0; r < s::kFrameRows; ++r) frame_rows[frame_names[r]] = r;
  const char* pulse_names[] = {"tx", "ty", "t2", "tn", "rx", "ry", "r2", "rn", "offset",
                               "dtx", "dty", "dtz", "dt2", "drx", "dry", "drz", "dr2", "centre_offset",
                               "inv_bin", "kc"};
  for (int r = 0; r < s::kPulseRows; ++r) pulse_rows[pulse_names[r]] = r;
  static_assert(sizeof frame_names / sizeof *frame_names == s::kFrameRows, "a name per frame row");
  static_assert(sizeof pulse_names / sizeof *pulse_names == s::kPulseRows, "a name per pulse row");
  m.attr("FRAME_ROWS") = frame_rows;
  // the interpolators by name: (code, taps), as sarcli.core.sampling.INTERPOLATORS names them
  nanobind::dict interpolators;
  for (int k = sarcli::interp::kLinear; k < sarcli::interp::kKinds; ++k)
    interpolators[sarcli::interp::kNames[k]] = nanobind::make_tuple(k, sarcli::interp::kTaps[k]);
  m.attr("INTERPOLATORS") = interpolators;
  m.attr("PULSE_ROWS") = pulse_rows;
  // outputs are written in place: never an implicit (converted) copy
  nb::class_<s::Stage0Options>(m, "Stage0Options", "Stage 0's scalar settings.")
      .def(nb::init<>())
      .def("__init__",
           [](s::Stage0Options* o, int kind, bool bistatic, double half_len, double n_len, int pad, double dq,
              double kref) { new (o) s::Stage0Options{kind, bistatic, half_len, n_len, pad, dq, kref}; },
           nb::kw_only(), "kind"_a, "bistatic"_a, "half_len"_a, "n_len"_a, "pad"_a, "dq"_a, "kref"_a)
      .def_rw("kind", &s::Stage0Options::kind)
      .def_rw("bistatic", &s::Stage0Options::bistatic)
      .def_rw("half_len", &s::Stage0Options::half_len)
      .def_rw("n_len", &s::Stage0Options::n_len)
      .def_rw("pad", &s::Stage0Options::pad)
      .def_rw("dq", &s::Stage0Options::dq)
      .def_rw("kref", &s::Stage0Options::kref)
      .def_rw("weights_first", &s::Stage0Options::weights_first);
  m.def("stage0", &s::stage0, "pre"_a, "pim"_a, "first"_a, "count"_a, "pulses"_a, "series"_a, "frame"_a, "rows"_a,
        "tab"_a, "options"_a, nb::arg("out_re").noconvert(), nb::arg("out_im").noconvert(),
        "Backproject each sub-aperture's pulses (first[s] .. +count[s]) onto its polar grid (out[s]): the nodes "
        "rows[s, row, 0] .. rows[s, row, 1]-1 of each row, zero elsewhere.");
  m.def("merge", &s::merge, "cre"_a, "cim"_a, "cframe"_a, "pframe"_a, "first"_a, "count"_a, "rows"_a, "tab_q"_a,
        "tab_t"_a, "kind"_a, "dq"_a, "kref"_a, nb::arg("out_re").noconvert(), nb::arg("out_im").noconvert(),
        "Parent sub-image s = sum of children first[s] .. +count[s] interpolated at its nodes rows[s, row, 0] .. "
        "rows[s, row, 1]-1 of each row, zero elsewhere.");
  m.def("final_stage", &s::final_stage, "cre"_a, "cim"_a, "cframe"_a, "x"_a, "y"_a, "tab_q"_a, "tab_t"_a,
        "kind"_a, "dq"_a, "kref"_a, nb::arg("img").noconvert(),
        "Add the sub-images, interpolated at every pixel and re-modulated, to img [ny, nx].");
  m.def("tone_weights", &s::tone_weights, "k"_a, "a"_a, "b"_a, "inv_h"_a, "inv_psi"_a, nb::arg("w").noconvert(),
        "w[p, j] *= prod_l inv_psi(|k_j a[l, p] + b| inv_h), linearly interpolated.");
  m.def("carrier_values", &s::carrier_values, "phase"_a, nb::arg("cos").noconvert(), nb::arg("sin").noconvert(),
        "(cos, sin) of float64 phases as the kernels evaluate them (float32).");
  m.def("row_weights", &s::weights_of<double>, "kind"_a, "frac"_a, "tab"_a, nb::arg("w").noconvert(),
        "Interpolation weights w[tap, i] of fractions frac (float64).");
  m.def("row_weights", &s::weights_of<float>, "kind"_a, "frac"_a, "tab"_a, nb::arg("w").noconvert(),
        "Interpolation weights w[tap, i] of fractions frac (float32, as the kernels use).");
}
