// Fast factorised backprojection's kernels (ffbp.cpp): the tables they read, by named row, and
// the entry points that bindings/ffbp.cpp binds. Python names the same rows in
// sarcli._native.layout (FFBP_FRAME, FFBP_PULSE), checked against these by the tests.
#pragma once

#include <complex>
#include <cstdint>

#include "sarcli_simd.hpp"

namespace sarcli {

// Rows of a frame table [kFrameRows, n], one column per sub-aperture's polar grid: its centre c
// (cx, cy, |c|), the ground distance ρ0 of c's nadir from the scene origin, the unit vector e0
// from that nadir towards the origin, cz, and the grid's origin and angular spacing (q0, u0, Δu).
enum FrameRow { kCx, kCy, kCn, kRho0, kE0x, kE0y, kCz, kQ0, kU0, kDu, kFrameRows };

// Rows of stage 0's pulse table [kPulseRows, B], one column per pulse: the exact range's inputs
// (transmit t: tx, ty, |t|², |t|; receive r: rx, ry, |r|², |r|; the offset (|t| + |r|)/2 − r0),
// the range series' (Δt = t − c: x, y, z, |Δt|²; Δr = r − c: x, y, z, |Δr|²; |c| − r0), the inverse
// profile bin and the carrier wavenumber.
enum PulseRow {
  kTx, kTy, kT2, kTn, kRx, kRy, kR2, kRn, kOffset,
  kDtx, kDty, kDtz, kDt2, kDrx, kDry, kDrz, kDr2, kCentreOffset,
  kInvBin, kKc, kPulseRows
};

// Stage 0's scalar settings (Python: Stage0Options(kind=, bistatic=, half_len=, n_len=, pad=, dq=, kref=)).
struct Stage0Options {
  int kind = 3;             // interpolation kernel of the profiles (kTaps)
  bool bistatic = false;    // separate receive positions in the pulse table
  double half_len = 0.0;    // L // 2: the profile bin of zero range
  double n_len = 0.0;       // L, the profile length
  int pad = 0;              // bins of padding on each side of the profiles
  double dq = 0.0;          // range spacing of the polar grids
  double kref = 0.0;        // reference wavenumber of the demodulation
  int weights_first = -1;   // 1, 0: whether stage0_row forms the 6-tap weights in a pass of their own; -1: as
                            // stage0_weights_first says for this CPU (the same sums either way)
};


void stage0(in<float, 2> pre, in<float, 2> pim, in<std::int64_t, 1> first, in<std::int64_t, 1> count,
            in<double, 2> pulses, in<bool, 1> series, in<double, 2> frame, in<std::int64_t, 3> rows, in<float, 2> tab,
            const Stage0Options& o, out<float, 3> out_re, out<float, 3> out_im);
void merge(in<float, 3> cre, in<float, 3> cim, in<double, 2> cframe, in<double, 2> pframe, in<std::int64_t, 1> first,
           in<std::int64_t, 1> count, in<std::int64_t, 3> rows, in<float, 2> tab_q, in<float, 2> tab_t, int kind,
           double dq, double kref, out<float, 3> out_re, out<float, 3> out_im);
void final_stage(in<float, 3> cre, in<float, 3> cim, in<double, 2> cframe, in<double, 1> x, in<double, 1> y,
                 in<float, 2> tab_q, in<float, 2> tab_t, int kind, double dq, double kref,
                 out<std::complex<double>, 2> img);
void tone_weights(in<double, 2> k, in<double, 2> a, double b, double inv_h, in<double, 1> inv_psi,
                  out<double, 2> w);
// The carrier (cos, sin) of float64 phases in float32, as the kernels evaluate it (for tests).
void carrier_values(in<double, 1> ph, out<float, 1> c, out<float, 1> s);
// The interpolation weights w[tap, i] of fractions frac as the kernels evaluate them (for tests).
template <typename T>
void weights_of(int kind, in<T, 1> frac, in<T, 2> tab, out<T, 2> w);

}  // namespace sarcli
