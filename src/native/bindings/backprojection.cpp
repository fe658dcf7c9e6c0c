// The Python module sarcli._native._backprojection: bindings of backprojection.hpp.
#include "backprojection.hpp"
#include "numerics/kinds.hpp"

NB_MODULE(_backprojection, m) {
  using namespace nanobind::literals;
  using namespace sarcli;
  m.doc() = "sarcli's backprojection loops: tiled forward kernel and its exact adjoint.";
  const char* bp_doc =
      "out[row, col] += sum_p w(Δr) profile_p(Δr) exp(+i kc_p Δr) over pulses (tiles of `width` "
      "pixels along rows, float64 anchors); geo rows: 2ax, 2ay, |a|², |a|, 2bx, 2by, |b|², |b|, "
      "offset, 1/bin, kc.";
  const char* rp_doc = "Adjoint of bp_tiles: h[p, :] += transposed interpolation of f exp(-i kc Δr).";
  m.def("bp_tiles", &bp_tiles<float>, "profiles"_a, "x"_a, "y"_a, "geo"_a, "n_len"_a, "pad"_a,
        "kind"_a, "bist"_a, "width"_a, "series"_a, "block"_a, "out_re"_a, "out_im"_a, bp_doc);
  m.def("bp_tiles", &bp_tiles<double>, "profiles"_a, "x"_a, "y"_a, "geo"_a, "n_len"_a, "pad"_a,
        "kind"_a, "bist"_a, "width"_a, "series"_a, "block"_a, "out_re"_a, "out_im"_a, bp_doc);
  m.def("rp_tiles", &rp_tiles<float>, "fre"_a, "fim"_a, "x"_a, "y"_a, "geo"_a, "n_len"_a, "pad"_a,
        "kind"_a, "bist"_a, "width"_a, "series"_a, "h"_a, rp_doc);
  m.def("rp_tiles", &rp_tiles<double>, "fre"_a, "fim"_a, "x"_a, "y"_a, "geo"_a, "n_len"_a, "pad"_a,
        "kind"_a, "bist"_a, "width"_a, "series"_a, "h"_a, rp_doc);
  const char* ct_doc =
      "acc[p] = sum over pixels of g · (pulse p's part of bp_tiles), (re, im): the per-pulse "
      "derivative of an image functional with gradient g, by gathering from the profiles.";
  m.def("bp_contract", &bp_contract<float>, "profiles"_a, "gre"_a, "gim"_a, "x"_a, "y"_a, "geo"_a,
        "n_len"_a, "pad"_a, "kind"_a, "bist"_a, "width"_a, "series"_a, "block"_a, "acc"_a.noconvert(), ct_doc);
  m.def("bp_contract", &bp_contract<double>, "profiles"_a, "gre"_a, "gim"_a, "x"_a, "y"_a, "geo"_a,
        "n_len"_a, "pad"_a, "kind"_a, "bist"_a, "width"_a, "series"_a, "block"_a, "acc"_a.noconvert(), ct_doc);
  const char* pt_doc =
      "out[i] += sum_p w(Δr) profile_p(Δr) exp(+i kc_p Δr) at 3-D pixels pts[i] (exact float64 ranges); "
      "geo rows: ax, ay, az, bx, by, bz, |a|, |b|, offset, 1/bin, kc.";
  const char* rpt_doc = "Adjoint of bp_points: h[p, :] += transposed interpolation of f exp(-i kc Δr).";
  m.def("bp_points", &bp_points<float>, "profiles"_a, "pts"_a, "geo"_a, "n_len"_a, "pad"_a, "kind"_a, "bist"_a,
        "out_re"_a.noconvert(), "out_im"_a.noconvert(), pt_doc);
  m.def("bp_points", &bp_points<double>, "profiles"_a, "pts"_a, "geo"_a, "n_len"_a, "pad"_a, "kind"_a, "bist"_a,
        "out_re"_a.noconvert(), "out_im"_a.noconvert(), pt_doc);
  m.def("rp_points", &rp_points<float>, "fre"_a, "fim"_a, "pts"_a, "geo"_a, "n_len"_a, "pad"_a, "kind"_a,
        "bist"_a, "h"_a.noconvert(), rpt_doc);
  m.def("rp_points", &rp_points<double>, "fre"_a, "fim"_a, "pts"_a, "geo"_a, "n_len"_a, "pad"_a, "kind"_a,
        "bist"_a, "h"_a.noconvert(), rpt_doc);
  // the geometry tables' rows by name (sarcli._native.layout names the same rows)
  nanobind::dict geo_rows, point_rows;
  const char* geo_names[] = {"two_ax", "two_ay", "a2", "na", "two_bx", "two_by", "b2", "nb", "offset", "inv_bin", "kc"};
  const char* point_names[] = {"ax", "ay", "az", "bx", "by", "bz", "na", "nb", "offset", "inv_bin", "kc"};
  static_assert(sizeof geo_names / sizeof *geo_names == kGeoRows, "a name per geometry row");
  static_assert(sizeof point_names / sizeof *point_names == kPtRows, "a name per geometry row");
  for (int r = 0; r < kGeoRows; ++r) geo_rows[geo_names[r]] = r;
  for (int r = 0; r < kPtRows; ++r) point_rows[point_names[r]] = r;
  m.attr("GEO_ROWS") = geo_rows;
  // the interpolators by name: (code, taps), as sarcli.core.sampling.INTERPOLATORS names them
  nanobind::dict interpolators;
  for (int k = interp::kLinear; k < interp::kKinds; ++k)
    if (interp::profile_kind(k)) interpolators[interp::kNames[k]] = nanobind::make_tuple(k, interp::kTaps[k]);
  m.attr("INTERPOLATORS") = interpolators;
  m.attr("POINT_ROWS") = point_rows;
  m.def("isa_level", &isa_level, "The kernels' instruction set here: 2 AVX-512, 1 AVX2, 0 baseline.");
  m.def("carrier_values", &carrier_values, "phase"_a, "cos"_a, "sin"_a,
        "(cos, sin) of float64 phases as the kernels evaluate them (float32).");
  m.def("carrier_turn_values", &carrier_turn_values, "turns"_a, "cos"_a, "sin"_a,
        "(cos, sin) of 2π q for float64 phases q in turns as the tiled kernels evaluate them (float32).");
  m.def("weight_values", &weight_values, "t"_a, "kind"_a, "w"_a,
        "Interpolation weights at fractions t (kind 0 linear, 1 Keys cubic, 2 Lanczos-3, 4 cubic Lagrange).");
}
