// Vectorisable (cos, sin) of a carrier phase: Cody-Waite reduction and minimax polynomials, the
// same constants and operation order as sarcli.formers._bp_kernels._carrier_constants /
// _sincos_half (so compiled kernels in C++ give the bits of the numba ones, to FMA contraction).
//
//   hp = phase / 2;  k = rint(hp / π);  h = ((hp − k·hi) − k·mid) − k·lo  in [−π/2, π/2]
//   sin h = h (1 + h² S(h²)),  cos h = 1 + h² C(h²)       (minimax, S and C of degree 3 or 7)
//   (cos, sin)(2h) by the double-angle formulas.
//
// hi + mid + lo = π, with hi short enough that k·hi is exact (26 bits in float64, 10 in float32).
// Self-contained (no nanobind): any kernel family may include it.
#pragma once

#include <cmath>

namespace sarcli {
namespace carrier {

// float64: polynomial error 4.9e-19 (sine), 4.2e-18 (cosine) on |h| <= π/2
constexpr double kInvPi = 0x1.45f306dc9c883p-2;
constexpr double kPiHi = 0x1.921fb58000000p+1, kPiMid = -0x1.dde973dcb3b3ap-26, kPiLo = 0x1.8a2e03707344ap-80;
constexpr double kS64[8] = {-0x1.5555555555555p-3, 0x1.11111111110dap-7, -0x1.a01a01a015a13p-13,
                            0x1.71de3a52e04a1p-19, -0x1.ae6454e8d74abp-26, 0x1.6123d05841e91p-33,
                            -0x1.ae43fdf9c095ap-41, 0x1.8836c6cbb7cbcp-49};
constexpr double kC64[8] = {-0x1.ffffffffffffdp-2, 0x1.555555555540ap-5, -0x1.6c16c16c0b21dp-10,
                            0x1.a01a0199c9289p-16, -0x1.27e4f9915fc1fp-22, 0x1.1eece48a37755p-29,
                            -0x1.9351e132d5963p-37, 0x1.9f422567ac97dp-45};
// float32: polynomial error 1.0e-8 (sine), 5.3e-8 (cosine) on |h| <= π/2
constexpr float kS32[4] = {-0x1.55554ep-3f, 0x1.110ef8p-7f, -0x1.9f71b0p-13f, 0x1.5da682p-19f};
constexpr float kC32[4] = {-0x1.ffffd2p-2f, 0x1.554fb8p-5f, -0x1.6b398ep-10f, 0x1.852322p-16f};

// (cos, sin) of 2·hp, float64 throughout: error ~7e-16 plus the reduction's ~1e-15·|k|.
inline __attribute__((always_inline)) void sincos_half(double hp, double& c, double& s) {
  const double k = std::nearbyint(hp * kInvPi);
  const double h = ((hp - k * kPiHi) - k * kPiMid) - k * kPiLo;
  const double h2 = h * h;
  const double ps = kS64[0] + h2 * (kS64[1] + h2 * (kS64[2] + h2 * (kS64[3] + h2 * (kS64[4] + h2 * (
      kS64[5] + h2 * (kS64[6] + h2 * kS64[7]))))));
  const double pc = kC64[0] + h2 * (kC64[1] + h2 * (kC64[2] + h2 * (kC64[3] + h2 * (kC64[4] + h2 * (
      kC64[5] + h2 * (kC64[6] + h2 * kC64[7]))))));
  const double sh = h * (1.0 + h2 * ps), ch = 1.0 + h2 * pc;
  c = ch * ch - sh * sh;
  s = 2.0 * sh * ch;
}

// (cos, sin) of a float64 phase ph (= sincos_half(ph / 2)).
inline __attribute__((always_inline)) void sincos(double ph, double& c, double& s) {
  sincos_half(0.5 * ph, c, s);
}

// (cos, sin) of 2·h for a reduced half angle |h| <= π/2: the float32 half-angle polynomials, then
// the double-angle formulas.
inline __attribute__((always_inline)) void double_angle_f32(float h, float& c, float& s) {
  const float h2 = h * h;
  const float ps = kS32[0] + h2 * (kS32[1] + h2 * (kS32[2] + h2 * kS32[3]));
  const float pc = kC32[0] + h2 * (kC32[1] + h2 * (kC32[2] + h2 * kC32[3]));
  const float sh = h * (1.0f + h2 * ps), ch = 1.0f + h2 * pc;
  c = ch * ch - sh * sh;
  s = 2.0f * sh * ch;
}

// (cos, sin) of 2·hp in float32 after a float64 reduction: the reduced half angle is exact to
// float64 rounding whatever |hp|, and the float32 polynomials add ~1e-7 (a float32 carrier for
// float32 data: the reduction, not the polynomial, is what needs float64 at large phases).
inline __attribute__((always_inline)) void sincos_half_f32(double hp, float& c, float& s) {
  const double k = std::nearbyint(hp * kInvPi);
  const float h = static_cast<float>(((hp - k * kPiHi) - k * kPiMid) - k * kPiLo);
  double_angle_f32(h, c, s);
}

// (cos, sin) of a float32 phase of moderate size (|ph| up to ~1e4: k·2π_hi stays exact): a float32
// Cody-Waite reduction to [−π, π], then the float32 half-angle polynomials. For phases already
// reduced in float64 and carried a few radians further in float32 (stage 0 of ffbp).
constexpr float kTwoPiHi32 = 6.28125f, kTwoPiLo32 = 0x1.fb5444p-10f;   // hi + lo = 2π (hi: 9 bits)
inline __attribute__((always_inline)) void sincos_f32(float ph, float& c, float& s) {
  constexpr float kRound = 12582912.0f;   // 1.5·2^23: adding and subtracting it rounds to an integer
  const float k = (ph * 0.159154943f + kRound) - kRound;
  const float h = 0.5f * ((ph - k * kTwoPiHi32) - k * kTwoPiLo32);
  double_angle_f32(h, c, s);
}

}  // namespace carrier
}  // namespace sarcli
