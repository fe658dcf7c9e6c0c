// Backprojection's kernels (backprojection.cpp): the per-pulse tables they read, by named row,
// and the entry points that bindings/backprojection.cpp binds. Python names the same rows in
// sarcli._native.layout (BP_GEO, BP_POINT_GEO), checked against these by the tests.
#pragma once

#include "sarcli_simd.hpp"

namespace sarcli {

// Rows of the tiled kernels' per-pulse geometry [kGeoRows, B] (transmit a, receive b): 2a_x, 2a_y,
// |a|², |a|, 2b_x, 2b_y, |b|², |b|, the range offset (|a| + |b|)/2 − r0, 1/bin and the carrier
// wavenumber kc.
enum Geo { G2AX, G2AY, GA2, GNA, G2BX, G2BY, GB2, GNB, GOFF, GIB, GKC, kGeoRows };

// Rows of the terrain kernels' per-pulse geometry [kPtRows, B]: a_x, a_y, a_z, b_x, b_y, b_z, |a|,
// |b|, the range offset, 1/bin and kc.
enum PtGeo { PAX, PAY, PAZ, PBX, PBY, PBZ, PNA, PNB, POFF, PIB, PKC, kPtRows };

template <typename PT>
void bp_tiles(in<PT, 3> prof, in<double, 1> x, in<double, 1> y, in<double, 2> geo, long n_len, long pad, int kind,
              bool bist, long width, bool series, long block, out<double, 2> ore, out<double, 2> oim);
template <typename PT>
void rp_tiles(in<PT, 2> fre, in<PT, 2> fim, in<double, 1> x, in<double, 1> y, in<double, 2> geo, long n_len,
              long pad, int kind, bool bist, long width, bool series, out<PT, 3> h);
template <typename PT>
void bp_contract(in<PT, 3> prof, in<PT, 2> gre, in<PT, 2> gim, in<double, 1> x, in<double, 1> y,
                 in<double, 2> geo, long n_len, long pad, int kind, bool bist, long width, bool series,
                 long block, out<double, 2> acc);
template <typename PT>
void bp_points(in<PT, 3> prof, in<double, 2> pts, in<double, 2> geo, long n_len, long pad, int kind, bool bist,
               out<double, 1> ore, out<double, 1> oim);
template <typename PT>
void rp_points(in<PT, 1> fre, in<PT, 1> fim, in<double, 2> pts, in<double, 2> geo, long n_len, long pad, int kind,
               bool bist, out<PT, 3> h);
// 2: AVX-512, 1: AVX2 + FMA, 0: baseline x86-64 ($SARCLI_BP_ISA caps it, for tests and timing).
int isa_level();
// The carrier and interpolation weights as the kernels evaluate them (for tests).
void carrier_values(in<double, 1> ph, out<float, 1> c, out<float, 1> s);
// The tiled kernels' carrier of phases in turns, (cos, sin)(2π q) (for tests).
void carrier_turn_values(in<double, 1> q, out<float, 1> c, out<float, 1> s);
void weight_values(in<float, 1> t, int kind, out<float, 2> w);

}  // namespace sarcli
