// The kernels' sine and cosine: one home for each precision, the arithmetic every family uses.
//
// float32 (a carrier for float32 interpolation; backprojection, its terrain kernels, ffbp's stage 0,
// merges and final stage, the Lanczos weights): Cody-Waite reduction and minimax polynomials of the
// half angle, then the double-angle formulas,
//
//   hp = phase / 2;  k = rint(hp / π);  h = ((hp − k·hi) − k·mid) − k·lo  in [−π/2, π/2]
//   sin h = h (1 + h² S(h²)),  cos h = 1 + h² C(h²)       (minimax, S and C of degree 3)
//   (cos, sin)(2h) by the double-angle formulas,
//
// with hi + mid + lo = π and hi short enough (26 bits) that k·hi is exact.
//
// float64 (the exact matched filter, sarcli.formers.direct): Cephes' (Moshier) polynomials on
// [−π/4, π/4] after a three-part Cody–Waite reduction by π/2, without branches so that a group of
// lanes runs as one vector; within 2 ulp of the correctly rounded values for |x| < 1e8.
//
// Self-contained (no nanobind): any kernel family may include it.
#pragma once

#include <cmath>
#include <cstdint>
#include <cstring>

#include "numerics/inline.hpp"

namespace sarcli {
namespace carrier {

constexpr double kInvPi = 0x1.45f306dc9c883p-2;
constexpr double kPiHi = 0x1.921fb58000000p+1, kPiMid = -0x1.dde973dcb3b3ap-26, kPiLo = 0x1.8a2e03707344ap-80;
// float32: polynomial error 1.0e-8 (sine), 5.3e-8 (cosine) on |h| <= π/2
constexpr float kS32[4] = {-0x1.55554ep-3f, 0x1.110ef8p-7f, -0x1.9f71b0p-13f, 0x1.5da682p-19f};
constexpr float kC32[4] = {-0x1.ffffd2p-2f, 0x1.554fb8p-5f, -0x1.6b398ep-10f, 0x1.852322p-16f};

// (cos, sin) of 2·h for a reduced half angle |h| <= π/2: the float32 half-angle polynomials, then
// the double-angle formulas.
SARCLI_INLINE void double_angle_f32(float h, float& c, float& s) {
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
SARCLI_INLINE void sincos_half_f32(double hp, float& c, float& s) {
  const double k = std::nearbyint(hp * kInvPi);
  const float h = static_cast<float>(((hp - k * kPiHi) - k * kPiMid) - k * kPiLo);
  double_angle_f32(h, c, s);
}

// (cos, sin) of a float64 phase ph in float32 (= sincos_half_f32(ph / 2)).
SARCLI_INLINE void cos_sin_f32(double ph, float& c, float& s) { sincos_half_f32(0.5 * ph, c, s); }

// (cos, sin) of 2π·q, a phase q in turns, in float32: r = q − rint(q) in [−1/2, 1/2] is exact in
// float64 whatever |q|, and the half angle h = π r is rounded once to float32 (the same ~1e-7 as
// cos_sin_f32); three operations a value where cos_sin_f32's reduction takes five. For phases
// that a kernel evaluates in turns from anchors reduced with cos_sin_f32's care (backprojection).
constexpr double kPi = 3.141592653589793;
SARCLI_INLINE void cos_sin_turns_f32(double q, float& c, float& s) {
  const double r = q - std::nearbyint(q);
  double_angle_f32(static_cast<float>(kPi * r), c, s);
}

// cos_sin_f32 of a phase |ph| < π, whose half angle needs no reduction (k = 0 there): the same
// bits without the reduction's work (the Lanczos weights' sines).
SARCLI_INLINE void cos_sin_small_f32(double ph, float& c, float& s) {
  double_angle_f32(static_cast<float>(0.5 * ph), c, s);
}

// (cos, sin) of a float32 phase of moderate size (|ph| up to ~1e4: k·2π_hi stays exact): a float32
// Cody-Waite reduction to [−π, π], then the float32 half-angle polynomials. For phases already
// reduced in float64 and carried a few radians further in float32 (stage 0 of ffbp).
constexpr float kTwoPiHi32 = 6.28125f, kTwoPiLo32 = 0x1.fb5444p-10f;   // hi + lo = 2π (hi: 9 bits)
SARCLI_INLINE void sincos_f32(float ph, float& c, float& s) {
  constexpr float kRound = 12582912.0f;   // 1.5·2^23: adding and subtracting it rounds to an integer
  const float k = (ph * 0.159154943f + kRound) - kRound;
  const float h = 0.5f * ((ph - k * kTwoPiHi32) - k * kTwoPiLo32);
  double_angle_f32(h, c, s);
}

// |x| up to which sin_cos holds its accuracy (the reduction is exact to 2^29 π/2).
constexpr double kExactArg = 1e8;

// sin x and cos x in float64: x = q π/2 + r with |r| <= π/4, then the quadrant q mod 4 picks and
// signs the polynomials. π/2 = 2 (DP1 + DP2 + DP3), each part 24 bits, so q DPi is exact for
// |q| < 2^29.
SARCLI_INLINE void sin_cos(double x, double& s_out, double& c_out) {
  constexpr double kTwoOverPi = 0.63661977236758134308;
  constexpr double kShift = 6755399441055744.0;  // 1.5 2^52: adding it rounds to an integer
  constexpr double P1 = 2 * 7.85398125648498535156e-1, P2 = 2 * 3.77489470793079817668e-8,
                   P3 = 2 * 2.69515142907905952645e-15;
  const double t = x * kTwoOverPi + kShift;
  const double q = t - kShift;
  std::uint64_t qi;
  std::memcpy(&qi, &t, sizeof qi);  // low bits: q in two's complement
  const double r = ((x - q * P1) - q * P2) - q * P3;
  const double z = r * r;
  const double ps = ((((1.58962301576546568060e-10 * z - 2.50507477628578072866e-8) * z +
                       2.75573136213857245213e-6) * z - 1.98412698295895385996e-4) * z +
                     8.33333333332211858878e-3) * z - 1.66666666666666307295e-1;
  const double pc = ((((-1.13585365213876817300e-11 * z + 2.08757008419747316778e-9) * z -
                       2.75573141792967388112e-7) * z + 2.48015872888517045348e-5) * z -
                     1.38888888888730564116e-3) * z + 4.16666666666665929218e-2;
  const double sr = r + r * z * ps;
  const double cr = 1.0 - 0.5 * z + z * z * pc;
  std::uint64_t sb, cb;
  std::memcpy(&sb, &sr, sizeof sb);
  std::memcpy(&cb, &cr, sizeof cb);
  const std::uint64_t swap = 0 - (qi & 1);  // odd quadrant: sin x = ±cos r, cos x = ∓sin r
  std::uint64_t so = (sb & ~swap) | (cb & swap), co = (cb & ~swap) | (sb & swap);
  so ^= (qi & 2) << 62;
  co ^= ((qi + 1) & 2) << 62;
  std::memcpy(&s_out, &so, sizeof so);
  std::memcpy(&c_out, &co, sizeof co);
}

}  // namespace carrier
}  // namespace sarcli
