// Backprojection (sarcli.formers.backprojection) and its exact adjoint, reprojection.
//
// The image is cut into tiles of up to 128 pixels along a row. Per tile and pulse the differential
// range at the tile's anchor (its centre) and its first two derivatives along the row come from
// float64 geometry; inside the tile each pixel's range offset u from the anchor enters through
//     Δr(u) = Δr_c + d1 u + d2 u²,
// d2 = (1 - c²) / (2R) and d1 = c + (3/4) h² d3 (c the direction cosine along the row, d3 the
// cubic Taylor coefficient -c (1 - c²) / (2R²), h the tile's half width: the Chebyshev
// economisation of the cubic term, which leaves at most |d3| h³ / 4 of model error). Near the
// radar that error (∝ h³/R²) narrows the tiles to a few pixels; there the series model (Args::series,
// SeriesAnchor) keeps the plain Taylor quadratic (d1 = c) and adds each pixel's departure ρ from it,
// the range's Taylor series from u³ to u⁹, in float32. Python picks the model and the tile width that keep the error far below the
// interpolation's at the least cost (sarcli.formers.backprojection._kernels.tiling). A tile's pixels run as groups
// of 16 SIMD lanes, its accumulators stay in registers over a block of pulses whose profiles stay
// in cache, and each lane reads its stencil as one contiguous vector (profiles interleave real
// and imaginary parts) that is transposed in registers. The profile position is kept
// relative to an integer bin of the anchor and evaluated in float32; the carrier phase
// kc Δr(u) in float64 turns (the anchor's part reduced first), reduced to half a turn either side
// (exactly) and evaluated by a float32 polynomial. The interpolation
// weights and the carrier are therefore float32 in every precision; the profiles and the
// accumulation are float32 or float64 (the template's PT). The forward and adjoint kernels share
// one inline evaluation of these weights, so reprojection is the transpose of the same matrix.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <string>
#include <vector>

#if defined(__x86_64__)
// GCC 12's AVX-512 headers build their "undefined" vectors from themselves, which its
// -Wmaybe-uninitialized reports at every inlined shuffle (GCC bug 105593, fixed in GCC 13): the
// warning is silenced for the header's lines only.
#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
#endif
#include <immintrin.h>
#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC diagnostic pop
#endif
#endif

#include "backprojection.hpp"
#include "numerics/keys.hpp"
#include "numerics/kinds.hpp"
#include "numerics/lanczos.hpp"
#include "numerics/sincos.hpp"
#include "sarcli_simd.hpp"

namespace sarcli {
namespace {

constexpr int kLanes = 16;
constexpr int kGroups = 8;  // lane groups a tile may hold (tiles of up to 128 pixels)
constexpr double kTwoPi = 6.283185307179586;
constexpr double kInvTwoPi = 0.15915494309189535;
constexpr double kTwoPiLo = 2.4492935982947064e-16;  // 2π - kTwoPi


template <int K>
struct Kernel;
template <>
struct Kernel<interp::kLinear> {
  static constexpr int taps = interp::kTaps[interp::kLinear], first = 0;
  static SARCLI_INLINE void weights(const float* t, float (*w)[kLanes]) {
#pragma omp simd
    for (int i = 0; i < kLanes; ++i) {
      w[0][i] = 1.0f - t[i];
      w[1][i] = t[i];
    }
  }
};
// The 4-tap kernels whose weights one function forms per fraction (numerics/keys.hpp).
template <int K, void (*Weights)(float, float*, std::size_t)>
struct Cubic4 {
  static constexpr int taps = interp::kTaps[K], first = 1;
  static SARCLI_INLINE void weights(const float* t, float (*w)[kLanes]) {
#pragma omp simd
    for (int i = 0; i < kLanes; ++i) Weights(t[i], &w[0][i], kLanes);
  }
};
template <>
struct Kernel<interp::kKeysCubic> : Cubic4<interp::kKeysCubic, interp::keys<float>> {};
template <>
struct Kernel<interp::kLagrange3> : Cubic4<interp::kLagrange3, interp::lagrange<float>> {};
template <>
struct Kernel<interp::kLanczos3> {
  static constexpr int taps = interp::kTaps[interp::kLanczos3], first = 2;
  static SARCLI_INLINE void weights(const float* t, float (*w)[kLanes]) {
    for (int i = 0; i < kLanes; ++i) {
      float v[6];
      interp::lanczos3(t[i], v);
      for (int k = 0; k < 6; ++k) w[k][i] = v[k];
    }
  }
};

// Everything a kernel call shares.
struct Args {
  const double* x;  // [nx] pixel x
  const double* y;  // [ny] pixel y
  const double* geo;  // [kGeoRows, B]
  long nx, ny, B, lp;  // lp: padded profile length n_len + 2 pad
  long n_len, pad, width;  // width: tile width <= kLanes * kGroups
  double half_len;
  bool bist;
  bool series;  // the series range model (SeriesAnchor) rather than the economised quadratic
};

// The series model's terms: u³ .. u⁹.
constexpr int kSeriesTerms = 7;

// The series range model's per-pulse terms at a tile's anchor: with u the pixel's offset along the
// row, each end's range R(u) = R_c √(1 + 2 c s + s²), s = u / R_c, departs from its quadratic
// R_c + c u + (1 - c²) u² / (2 R_c) by ρ(u) = Σ_{k>=3} b_k(c) u^k / R_c^(k-1), the Taylor series of
// the square root (b_k from the recurrence in series_end). SeriesLanes evaluates its terms u³ .. u⁹
// in float32 (a[k - 3]: a bistatic pair's mean) and adds them to the float64 quadratic.
struct SeriesAnchor {
  float a[kSeriesTerms];
  float ib, kc;  // bins and turns (Anchor) per metre of range
};

// Adds w times one end's series coefficients a_k = b_k / r^(k-1), k = 3 .. 9, to a: with
// √(1 + 2 c s + s²) = Σ b_k s^k, differentiating gives (1 + 2 c s + s²) F' = (c + s) F, so
// (k + 1) b_{k+1} = c (1 - 2k) b_k + (2 - k) b_{k-1}, from b_1 = c and b_2 = (1 - c²)/2. For
// |c| <= 1, |b_k| <= 4 |binom(1/2, k)| (the coefficients of (2 - √(1 - s))²): the truncation bound
// of _kernels.series_error. Coefficients below 1e-30 are flushed to zero (far ranges: no
// subnormal float32 operands in the lanes).
SARCLI_INLINE void series_end(double r, double c, double s2, double w, double* a) {
  const double ir = 1.0 / r;
  double bm = c, b = 0.5 * s2, sc = ir;
  for (int k = 2; k < 2 + kSeriesTerms; ++k) {
    const double bn = (c * (1 - 2 * k) * b + (2 - k) * bm) / (k + 1);
    bm = b;
    b = bn;
    sc *= ir;
    a[k - 2] += w * b * sc;
  }
}

// Tile anchor terms for one pulse (float64 geometry; see the file comment). ph0, ph1, ph2: the
// carrier's phase kc Δr in turns (SeriesAnchor::kc alike; ph0 reduced to [-1/2, 1/2] turn in
// radians first), the argument of carrier::cos_sin_turns_f32, whose reduction a lane is exact.
struct Anchor {
  int j0;
  float f0, s1, s2, lo, hi, top;
  double ph0, ph1, ph2;
};

// The same terms for a block of pulses, one array each (the pulse loop vectorises).
struct Anchors {
  std::vector<double> store;
  int* j0;
  float *f0, *s1, *s2, *lo, *hi, *top;
  double *ph0, *ph1, *ph2;
  // the contraction's per-pulse lane sums over a row, [n][2][kLanes] of the working precision
  std::vector<double> sums;
  // the series model's terms (filled only when Args::series), one array a field so that the pulse
  // loop vectorises: SeriesAnchor::a[k] at xf[k], ::ib at xf[kSeriesTerms], ::kc after it
  std::vector<float> xstore;
  float* xf[kSeriesTerms + 2];
  explicit Anchors(size_t n) : store(10 * n), sums(2 * kLanes * n), xstore((kSeriesTerms + 2) * n) {
    for (int k = 0; k < kSeriesTerms + 2; ++k) xf[k] = xstore.data() + k * n;
    double* d = store.data();
    ph0 = d; ph1 = d + n; ph2 = d + 2 * n;
    j0 = reinterpret_cast<int*>(d + 3 * n);
    float* f = reinterpret_cast<float*>(d + 4 * n);
    f0 = f; s1 = f + n; s2 = f + 2 * n; lo = f + 3 * n; hi = f + 4 * n; top = f + 5 * n;
  }
  SARCLI_INLINE void put_series(long i, const SeriesAnchor& x) {
    for (int k = 0; k < kSeriesTerms; ++k) xf[k][i] = x.a[k];
    xf[kSeriesTerms][i] = x.ib;
    xf[kSeriesTerms + 1][i] = x.kc;
  }
  SARCLI_INLINE SeriesAnchor series(long i) const {
    SeriesAnchor x;
    for (int k = 0; k < kSeriesTerms; ++k) x.a[k] = xf[k][i];
    x.ib = xf[kSeriesTerms][i];
    x.kc = xf[kSeriesTerms + 1][i];
    return x;
  }
  SARCLI_INLINE Anchor get(long i) const {
    return Anchor{j0[i], f0[i], s1[i], s2[i], lo[i], hi[i], top[i], ph0[i], ph1[i], ph2[i]};
  }
};

// One-way range terms at the anchor: Δr part, d1, d2 (3/4 h² d3 folded into d1); the range r,
// the direction cosine c along the row and 1 - c².
SARCLI_INLINE void one_way(double xc, double y, double two_ax, double two_ay, double a2, double na,
                           double he, double& dr, double& d1, double& d2, double& r, double& c,
                           double& s2) {
  const double num = xc * xc + y * y - two_ax * xc - two_ay * y;  // |x|² - 2 a·x
  r = std::sqrt(a2 + num);
  dr = num / (r + na);  // |a - x| - |a| without cancellation
  c = (xc - 0.5 * two_ax) / r;
  s2 = 1.0 - c * c;
  d2 = s2 / (2.0 * r);
  d1 = c - he * c * s2 / (2.0 * r * r);
}


// SER: fill ex with the series model's terms too.
template <bool BIST, bool SER>
SARCLI_INLINE Anchor anchor(const Args& A, long p, double xc, double y, double he, SeriesAnchor& ex) {
  const double* g = A.geo;
  const long B = A.B;
  double dr, d1, d2, r, c, s2;
  one_way(xc, y, g[G2AX * B + p], g[G2AY * B + p], g[GA2 * B + p], g[GNA * B + p], he, dr, d1, d2,
          r, c, s2);
  double a[kSeriesTerms] = {};
  if (SER) series_end(r, c, s2, BIST ? 0.5 : 1.0, a);
  if (BIST) {
    double drb, d1b, d2b, rb, cb, s2b;
    one_way(xc, y, g[G2BX * B + p], g[G2BY * B + p], g[GB2 * B + p], g[GNB * B + p], he, drb, d1b,
            d2b, rb, cb, s2b);
    if (SER) series_end(rb, cb, s2b, 0.5, a);
    dr = 0.5 * (dr + drb);
    d1 = 0.5 * (d1 + d1b);
    d2 = 0.5 * (d2 + d2b);
  }
  dr += g[GOFF * B + p];
  const double ib = g[GIB * B + p], kc = g[GKC * B + p];
  if (SER) {
    for (int k = 0; k < kSeriesTerms; ++k)
      ex.a[k] = std::fabs(a[k]) < 1e-30 ? 0.0f : static_cast<float>(a[k]);
    ex.ib = static_cast<float>(ib);
    ex.kc = static_cast<float>(kInvTwoPi * kc);
  }
  const double n_len = static_cast<double>(A.n_len);
  double sc = dr * ib + A.half_len;
  sc = std::min(std::max(sc, -4.0e6), 4.0e6);  // anchors far outside the window stay exact in float
  const double fj = std::floor(sc);
  Anchor an;
  an.j0 = static_cast<int>(fj);
  an.f0 = static_cast<float>(sc - fj);
  an.s1 = static_cast<float>(d1 * ib);
  an.s2 = static_cast<float>(d2 * ib);
  an.lo = static_cast<float>(-fj);
  an.hi = static_cast<float>(n_len - fj);
  an.top = static_cast<float>(n_len - 1.0 - fj);
  const double ph = kc * dr;
  const double k = std::rint(ph * kInvTwoPi);
  an.ph0 = kInvTwoPi * ((ph - k * kTwoPi) - k * kTwoPiLo);
  an.ph1 = kInvTwoPi * kc * d1;
  an.ph2 = kInvTwoPi * kc * d2;
  return an;
}

// anchor() for pulses [p0, p1) into `an` (a loop the compiler vectorises over pulses).
SARCLI_INLINE void anchors(const Args& A, long p0, long p1, double xc, double y, double he,
                           Anchors& an) {
  int* __restrict j0 = an.j0;
  float *__restrict f0 = an.f0, *__restrict s1 = an.s1, *__restrict s2 = an.s2;
  float *__restrict lo = an.lo, *__restrict hi = an.hi, *__restrict top = an.top;
  double *__restrict ph0 = an.ph0, *__restrict ph1 = an.ph1, *__restrict ph2 = an.ph2;
#define SARCLI_ANCHOR_LOOP(BIST, EX)                                                          \
  _Pragma("omp simd")                                                                           \
  for (long p = p0; p < p1; ++p) {                                                              \
    SeriesAnchor e;                                                                             \
    const Anchor a = anchor<BIST, EX>(A, p, xc, y, he, e);                                      \
    const long i = p - p0;                                                                      \
    j0[i] = a.j0; f0[i] = a.f0; s1[i] = a.s1; s2[i] = a.s2; lo[i] = a.lo; hi[i] = a.hi;         \
    top[i] = a.top; ph0[i] = a.ph0; ph1[i] = a.ph1; ph2[i] = a.ph2;                             \
    if (EX) an.put_series(i, e);                                                                \
  }
  if (A.bist) {
    if (A.series) {
      SARCLI_ANCHOR_LOOP(true, true)
    } else {
      SARCLI_ANCHOR_LOOP(true, false)
    }
  } else if (A.series) {
    SARCLI_ANCHOR_LOOP(false, true)
  } else {
    SARCLI_ANCHOR_LOOP(false, false)
  }
#undef SARCLI_ANCHOR_LOOP
}

// Per lane: first tap index (into the padded profile), interpolation weights, masked carrier.
template <int K>
struct Lanes {
  // where each lane's stencil starts in the profile (2 x its first tap's bin). The SIMD loaders
  // (Taps) read it through a volatile pointer: one vector store, then one scalar load a lane on
  // the load ports; left to itself the compiler extracts each index from the vector register,
  // three or four shuffle and integer instructions a lane that compete with the transposes.
  int idx[kLanes];
  float w[Kernel<K>::taps][kLanes];
  float c[kLanes], s[kLanes];
};

// The series model's departure from the quadratic at each lane (metres): ρ = u³ Σ a_k u^(k-3), by
// Horner in float32 (seven terms: six fused multiply-adds and three products a lane).
SARCLI_INLINE void series_lanes(const SeriesAnchor& x, const float* uf, float* rho) {
#pragma omp simd
  for (int i = 0; i < kLanes; ++i) {
    const float u = uf[i];
    float p = x.a[kSeriesTerms - 1];
    for (int k = kSeriesTerms - 2; k >= 0; --k) p = p * u + x.a[k];
    rho[i] = p * (u * u * u);
  }
}

// Each lane's profile position and carrier phase: the anchor's quadratic, plus with SER the
// series model's ρ (in bins and in radians).
template <int K, int SER, int ISA>
SARCLI_INLINE void eval_lanes(const Anchor& an, const SeriesAnchor* ex, const float* uf,
                              const double* ud, long pad, Lanes<K>& L) {
  const int base = an.j0 + static_cast<int>(pad) - Kernel<K>::first;
  float t[kLanes], m[kLanes], rho[kLanes];
  if (SER) series_lanes(*ex, uf, rho);
  const float ib = SER ? ex->ib : 0.0f, kc = SER ? ex->kc : 0.0f;
#pragma omp simd
  for (int i = 0; i < kLanes; ++i) {
    const float u = uf[i];
    float sp = an.f0 + u * (an.s1 + u * an.s2);
    if (SER) sp += ib * rho[i];
    m[i] = (sp >= an.lo && sp < an.hi) ? 1.0f : 0.0f;
    sp = std::min(std::max(sp, an.lo), an.top);
    const float fl = std::floor(sp);
    t[i] = sp - fl;
    L.idx[i] = 2 * (base + static_cast<int>(fl));
  }
#pragma omp simd
  for (int i = 0; i < kLanes; ++i) {
    const double v = ud[i];
    const double q = an.ph0 + v * (an.ph1 + v * an.ph2);
    float c, s;
    if (SER) {
      // the quadratic's turns reduced in float64, then ρ's turns added and the sum reduced in
      // float32 (one more float32 rounding of the sum; float64 would take twice the vectors for
      // the sum and its reduction)
      float f = static_cast<float>(q - std::nearbyint(q)) + kc * rho[i];
      f -= std::nearbyint(f);
      carrier::double_angle_f32(static_cast<float>(carrier::kPi) * f, c, s);
    } else {
      carrier::cos_sin_turns_f32(q, c, s);
    }
    L.c[i] = m[i] * c;
    L.s[i] = m[i] * s;
  }
  Kernel<K>::weights(t, L.w);
}

// The tile starting at column c0: its width, lane offsets from the anchor, and 3/4 h².
// A tile holds up to kGroups groups of kLanes pixels that share one anchor.
SARCLI_INLINE long tile_lanes(const Args& A, long c0, float (*uf)[kLanes], double (*ud)[kLanes],
                              double& xc, double& he) {
  const long wv = std::min<long>(A.width, A.nx - c0);
  const double xa = A.x[c0], xb = A.x[c0 + wv - 1];
  xc = 0.5 * (xa + xb);
  const double h = 0.5 * std::fabs(xb - xa);
  he = 0.75 * h * h;
  for (long g = 0; g * kLanes < wv; ++g)
    for (int i = 0; i < kLanes; ++i) {
      const long c = g * kLanes + i;
      ud[g][i] = c < wv ? A.x[c0 + c] - xc : 0.0;
      uf[g][i] = static_cast<float>(ud[g][i]);
    }
  return wv;
}

#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__)) && !defined(SARCLI_NO_CLONES)
#define SARCLI_BP_V4 __attribute__((target("arch=x86-64-v4")))
#define SARCLI_BP_V3 __attribute__((target("arch=x86-64-v3")))
#define SARCLI_BP_DISPATCH 1
#else
#define SARCLI_BP_V4
#define SARCLI_BP_V3
#define SARCLI_BP_DISPATCH 0
#endif

// The profile samples of every lane's stencil, transposed: t[2k][i] and t[2k + 1][i] are the real
// and imaginary parts of tap k of lane i (profiles interleave real and imaginary parts). The
// generic version reads them one by one; the AVX-512 and AVX2 versions below load each lane's
// stencil as one contiguous vector and transpose in registers. Keyed on the taps NT, so that the
// interpolators of one width (Keys and Lagrange: 4) share them.
template <typename PT, int NT, int ISA>
struct Taps {
  static SARCLI_INLINE void load(const PT* pp, const int* idx, PT (*t)[kLanes]) {
    for (int i = 0; i < kLanes; ++i) {
      const PT* q = pp + idx[i];
      for (int k = 0; k < 2 * NT; ++k) t[k][i] = q[k];
    }
  }
};

#if SARCLI_BP_DISPATCH
#define SARCLI_V4_INLINE __attribute__((target("arch=x86-64-v4"), always_inline)) inline
#define SARCLI_V3_INLINE __attribute__((target("arch=x86-64-v3"), always_inline)) inline
// the loaders: inlined once bp_row is inlined into a worker of the same target
#define SARCLI_V4_LOAD __attribute__((target("arch=x86-64-v4"))) inline
#define SARCLI_V3_LOAD __attribute__((target("arch=x86-64-v3"))) inline

// 8 x 8 transpose of floats within each 256-bit half of eight AVX-512 registers.
SARCLI_V4_INLINE void transpose8_v4(__m512* r) {
  __m512 t[8], u[8];
  for (int i = 0; i < 4; ++i) {
    t[2 * i] = _mm512_unpacklo_ps(r[2 * i], r[2 * i + 1]);
    t[2 * i + 1] = _mm512_unpackhi_ps(r[2 * i], r[2 * i + 1]);
  }
  for (int h = 0; h < 2; ++h) {
    u[4 * h + 0] = _mm512_shuffle_ps(t[4 * h + 0], t[4 * h + 2], 0x44);
    u[4 * h + 1] = _mm512_shuffle_ps(t[4 * h + 0], t[4 * h + 2], 0xEE);
    u[4 * h + 2] = _mm512_shuffle_ps(t[4 * h + 1], t[4 * h + 3], 0x44);
    u[4 * h + 3] = _mm512_shuffle_ps(t[4 * h + 1], t[4 * h + 3], 0xEE);
  }
  // 128-bit blocks: u[k] = [A0 A1 | B0 B1], u[k + 4] = [C0 C1 | D0 D1] -> [A0 C0 | B0 D0], [A1 C1 | B1 D1]
  const __m512i lo = _mm512_setr_epi32(0, 1, 2, 3, 16, 17, 18, 19, 8, 9, 10, 11, 24, 25, 26, 27);
  const __m512i hi = _mm512_setr_epi32(4, 5, 6, 7, 20, 21, 22, 23, 12, 13, 14, 15, 28, 29, 30, 31);
  for (int k = 0; k < 4; ++k) {
    r[k] = _mm512_permutex2var_ps(u[k], lo, u[k + 4]);
    r[k + 4] = _mm512_permutex2var_ps(u[k], hi, u[k + 4]);
  }
}

// 8 x 8 transpose of floats in eight AVX2 registers.
SARCLI_V3_INLINE void transpose8_v3(__m256* r) {
  __m256 t[8], u[8];
  for (int i = 0; i < 4; ++i) {
    t[2 * i] = _mm256_unpacklo_ps(r[2 * i], r[2 * i + 1]);
    t[2 * i + 1] = _mm256_unpackhi_ps(r[2 * i], r[2 * i + 1]);
  }
  for (int h = 0; h < 2; ++h) {
    u[4 * h + 0] = _mm256_shuffle_ps(t[4 * h + 0], t[4 * h + 2], 0x44);
    u[4 * h + 1] = _mm256_shuffle_ps(t[4 * h + 0], t[4 * h + 2], 0xEE);
    u[4 * h + 2] = _mm256_shuffle_ps(t[4 * h + 1], t[4 * h + 3], 0x44);
    u[4 * h + 3] = _mm256_shuffle_ps(t[4 * h + 1], t[4 * h + 3], 0xEE);
  }
  for (int k = 0; k < 4; ++k) {
    r[k] = _mm256_permute2f128_ps(u[k], u[k + 4], 0x20);
    r[k + 4] = _mm256_permute2f128_ps(u[k], u[k + 4], 0x31);
  }
}

// float, 4 taps (8 floats a lane), AVX-512: lanes i and i + 8 share a register.
template <>
struct Taps<float, 4, 2> {
  static SARCLI_V4_LOAD void load(const float* pp, const int* idx_, float (*t)[kLanes]) {
    const volatile int* idx = idx_;  // see Lanes::idx
    __m512 r[8];
    for (int i = 0; i < 8; ++i)
      r[i] = _mm512_insertf32x8(_mm512_castps256_ps512(_mm256_loadu_ps(pp + idx[i])),
                                _mm256_loadu_ps(pp + idx[i + 8]), 1);
    transpose8_v4(r);
    for (int k = 0; k < 8; ++k) _mm512_storeu_ps(t[k], r[k]);
  }
};

// float, 2 taps (4 floats a lane), AVX-512: lanes i, i + 4, i + 8, i + 12 share a register.
template <>
struct Taps<float, 2, 2> {
  static SARCLI_V4_LOAD void load(const float* pp, const int* idx_, float (*t)[kLanes]) {
    const volatile int* idx = idx_;  // see Lanes::idx
    __m512 r[4];
    for (int i = 0; i < 4; ++i) {
      __m512 v = _mm512_castps128_ps512(_mm_loadu_ps(pp + idx[i]));
      v = _mm512_insertf32x4(v, _mm_loadu_ps(pp + idx[i + 4]), 1);
      v = _mm512_insertf32x4(v, _mm_loadu_ps(pp + idx[i + 8]), 2);
      r[i] = _mm512_insertf32x4(v, _mm_loadu_ps(pp + idx[i + 12]), 3);
    }
    const __m512 t0 = _mm512_unpacklo_ps(r[0], r[1]), t1 = _mm512_unpackhi_ps(r[0], r[1]);
    const __m512 t2 = _mm512_unpacklo_ps(r[2], r[3]), t3 = _mm512_unpackhi_ps(r[2], r[3]);
    _mm512_storeu_ps(t[0], _mm512_shuffle_ps(t0, t2, 0x44));
    _mm512_storeu_ps(t[1], _mm512_shuffle_ps(t0, t2, 0xEE));
    _mm512_storeu_ps(t[2], _mm512_shuffle_ps(t1, t3, 0x44));
    _mm512_storeu_ps(t[3], _mm512_shuffle_ps(t1, t3, 0xEE));
  }
};

// double, 4 taps (8 doubles a lane), AVX-512: one register a lane, two 8 x 8 transposes.
template <>
struct Taps<double, 4, 2> {
  static SARCLI_V4_LOAD void load(const double* pp, const int* idx_, double (*t)[kLanes]) {
    const volatile int* idx = idx_;  // see Lanes::idx
    const __m512i lo = _mm512_setr_epi64(0, 1, 8, 9, 4, 5, 12, 13);
    const __m512i hi = _mm512_setr_epi64(2, 3, 10, 11, 6, 7, 14, 15);
    for (int g = 0; g < 2; ++g) {
      __m512d r[8], a[8], b[8];
      for (int i = 0; i < 8; ++i) r[i] = _mm512_loadu_pd(pp + idx[8 * g + i]);
      for (int i = 0; i < 4; ++i) {
        a[2 * i] = _mm512_unpacklo_pd(r[2 * i], r[2 * i + 1]);
        a[2 * i + 1] = _mm512_unpackhi_pd(r[2 * i], r[2 * i + 1]);
      }
      for (int h = 0; h < 2; ++h)
        for (int j = 0; j < 2; ++j) {
          b[4 * h + j] = _mm512_permutex2var_pd(a[4 * h + j], lo, a[4 * h + j + 2]);
          b[4 * h + j + 2] = _mm512_permutex2var_pd(a[4 * h + j], hi, a[4 * h + j + 2]);
        }
      for (int k = 0; k < 4; ++k) {
        _mm512_storeu_pd(t[k] + 8 * g, _mm512_shuffle_f64x2(b[k], b[k + 4], 0x44));
        _mm512_storeu_pd(t[k + 4] + 8 * g, _mm512_shuffle_f64x2(b[k], b[k + 4], 0xEE));
      }
    }
  }
};

// double, 4 taps, AVX2: two registers a lane, 4 x 4 transposes of four lanes at a time.
template <>
struct Taps<double, 4, 1> {
  static SARCLI_V3_LOAD void load(const double* pp, const int* idx_, double (*t)[kLanes]) {
    const volatile int* idx = idx_;  // see Lanes::idx
    for (int g = 0; g < 4; ++g)
      for (int h = 0; h < 2; ++h) {  // taps 0, 1 then 2, 3
        __m256d r[4];
        for (int i = 0; i < 4; ++i) r[i] = _mm256_loadu_pd(pp + idx[4 * g + i] + 4 * h);
        const __m256d t0 = _mm256_unpacklo_pd(r[0], r[1]), t1 = _mm256_unpackhi_pd(r[0], r[1]);
        const __m256d t2 = _mm256_unpacklo_pd(r[2], r[3]), t3 = _mm256_unpackhi_pd(r[2], r[3]);
        _mm256_storeu_pd(t[4 * h + 0] + 4 * g, _mm256_permute2f128_pd(t0, t2, 0x20));
        _mm256_storeu_pd(t[4 * h + 1] + 4 * g, _mm256_permute2f128_pd(t1, t3, 0x20));
        _mm256_storeu_pd(t[4 * h + 2] + 4 * g, _mm256_permute2f128_pd(t0, t2, 0x31));
        _mm256_storeu_pd(t[4 * h + 3] + 4 * g, _mm256_permute2f128_pd(t1, t3, 0x31));
      }
  }
};

// float, 4 taps, AVX2: two groups of eight lanes.
template <>
struct Taps<float, 4, 1> {
  static SARCLI_V3_LOAD void load(const float* pp, const int* idx_, float (*t)[kLanes]) {
    const volatile int* idx = idx_;  // see Lanes::idx
    for (int g = 0; g < 2; ++g) {
      __m256 r[8];
      for (int i = 0; i < 8; ++i) r[i] = _mm256_loadu_ps(pp + idx[8 * g + i]);
      transpose8_v3(r);
      for (int k = 0; k < 8; ++k) _mm256_storeu_ps(t[k] + 8 * g, r[k]);
    }
  }
};

// float, 2 taps, AVX2: lanes i and i + 4 of each group of eight share a register.
template <>
struct Taps<float, 2, 1> {
  static SARCLI_V3_LOAD void load(const float* pp, const int* idx_, float (*t)[kLanes]) {
    const volatile int* idx = idx_;  // see Lanes::idx
    for (int g = 0; g < 2; ++g) {
      __m256 r[4];
      for (int i = 0; i < 4; ++i)
        r[i] = _mm256_insertf128_ps(_mm256_castps128_ps256(_mm_loadu_ps(pp + idx[8 * g + i])),
                                    _mm_loadu_ps(pp + idx[8 * g + i + 4]), 1);
      const __m256 t0 = _mm256_unpacklo_ps(r[0], r[1]), t1 = _mm256_unpackhi_ps(r[0], r[1]);
      const __m256 t2 = _mm256_unpacklo_ps(r[2], r[3]), t3 = _mm256_unpackhi_ps(r[2], r[3]);
      _mm256_storeu_ps(t[0] + 8 * g, _mm256_shuffle_ps(t0, t2, 0x44));
      _mm256_storeu_ps(t[1] + 8 * g, _mm256_shuffle_ps(t0, t2, 0xEE));
      _mm256_storeu_ps(t[2] + 8 * g, _mm256_shuffle_ps(t1, t3, 0x44));
      _mm256_storeu_ps(t[3] + 8 * g, _mm256_shuffle_ps(t1, t3, 0xEE));
    }
  }
};

#endif

// Each lane's stencil of the profile pp, weighted (L from eval_lanes): vr + i vi = Σ w v.
template <typename PT, int K, int ISA>
SARCLI_INLINE void stencil_sums(const Lanes<K>& L, const PT* pp, PT* __restrict vr, PT* __restrict vi) {
  PT tp[2 * Kernel<K>::taps][kLanes];
  Taps<PT, Kernel<K>::taps, ISA>::load(pp, L.idx, tp);
#pragma omp simd
  for (int i = 0; i < kLanes; ++i) {
    PT r = 0, m = 0;
    for (int k = 0; k < Kernel<K>::taps; ++k) {
      r += static_cast<PT>(L.w[k][i]) * tp[2 * k][i];
      m += static_cast<PT>(L.w[k][i]) * tp[2 * k + 1][i];
    }
    vr[i] = r;
    vi[i] = m;
  }
}

// Pulse p's carried samples at one group of lanes whose ranges eval_lanes put in L: each lane's
// stencil sum times its carrier, (ur + i ui) = (Σ w v)(c + i s). The contraction weighs them by
// the image's gradient (the forward rows fold the product into their sums, RowItems::add).
template <typename PT, int K, int ISA>
SARCLI_INLINE void carry_lanes(const Lanes<K>& L, const PT* pp, PT* __restrict ur, PT* __restrict ui) {
  PT vr[kLanes], vi[kLanes];
  stencil_sums<PT, K, ISA>(L, pp, vr, vi);
#pragma omp simd
  for (int i = 0; i < kLanes; ++i) {
    const PT c = L.c[i], s = L.s[i];
    ur[i] = vr[i] * c - vi[i] * s;
    ui[i] = vr[i] * s + vi[i] * c;
  }
}

// eval_lanes then carry_lanes: pulse p's carried samples at one group of lanes.
template <typename PT, int K, int ISA, int SER>
SARCLI_INLINE void carried_lanes(const Anchor& a, const SeriesAnchor* ex, const float* uf, const double* ud,
                                 long pad, const PT* pp, Lanes<K>& L, PT* __restrict ur, PT* __restrict ui) {
  eval_lanes<K, SER, ISA>(a, ex, uf, ud, pad, L);
  carry_lanes<PT, K, ISA>(L, pp, ur, ui);
}

// The forward row's work item (pulse p0 + i, group g) in two steps: its lanes' ranges, weights
// and carrier (eval), then its stencils carried into the tile's accumulators (add).
template <typename PT, int K, int ISA, int SER>
struct RowItems {
  const Args& A;
  const PT* prof;
  const Anchors& an;
  long p0;
  const float (*uf)[kLanes];
  const double (*ud)[kLanes];
  PT (*ar)[kLanes];
  PT (*ai)[kLanes];
  SARCLI_INLINE void eval(long i, long g, Lanes<K>& L) const {
    const Anchor a = an.get(i);
    SeriesAnchor ex;
    if (SER) ex = an.series(i);
    eval_lanes<K, SER, ISA>(a, &ex, uf[g], ud[g], A.pad, L);
  }
  // the sums += (vr + i vi)(c + i s), as two fused multiply-adds a part
  SARCLI_INLINE void add(long i, long g, const Lanes<K>& L) const {
    PT vr[kLanes], vi[kLanes];
    stencil_sums<PT, K, ISA>(L, prof + 2 * (p0 + i) * A.lp, vr, vi);
    PT* __restrict gr = ar[g];
    PT* __restrict gi = ai[g];
#pragma omp simd
    for (int l = 0; l < kLanes; ++l) {
      const PT c = L.c[l], s = L.s[l];
      gr[l] = (gr[l] + vr[l] * c) - vi[l] * s;
      gi[l] = (gi[l] + vr[l] * s) + vi[l] * c;
    }
  }
};

// Forward: pulses [p0, p1) into image row `row` (accumulators in registers per tile); SER: the
// range model (0 the economised quadratic, 1 the series model). The
// (pulse, group) items run software-pipelined on AVX-512 (and AVX2's series model): the next item's lanes are
// evaluated before this item's stencils are loaded, so that the loads find their indices stored
// long before (the chain from a lane's range to its stencil's address is the loop's longest).
template <typename PT, int K, int ISA, int SER>
SARCLI_INLINE void bp_row_model(const Args& A, const PT* prof, long row, long p0, long p1,
                                Anchors& an, double* ore, double* oim) {
  const double y = A.y[row];
  float uf[kGroups][kLanes];
  double ud[kGroups][kLanes];
  Lanes<K> L0, L1;
  for (long c0 = 0; c0 < A.nx; c0 += A.width) {
    double xc, he;
    const long wv = tile_lanes(A, c0, uf, ud, xc, he);
    const long ng = (wv + kLanes - 1) / kLanes;
    anchors(A, p0, p1, xc, y, SER ? 0.0 : he, an);
    PT ar[kGroups][kLanes] = {}, ai[kGroups][kLanes] = {};
    const RowItems<PT, K, ISA, SER> it{A, prof, an, p0, uf, ud, ar, ai};
    // items j = 0 .. n - 1 in the order (pulse i = j / ng, group g = j % ng), two a turn so that
    // the two Lanes alternate without an index
    const long n = (p1 - p0) * ng;
    long i = 0, g = 0;
    // the plain order where the loop's arithmetic, not its latency, sets the pace: the baseline,
    // and AVX2 with the quadratic model (the series model's longer chain to the stencil's address
    // gains from the pipelined order there)
    if (ISA < 1 || (ISA == 1 && !SER)) {
      for (long j = 0; j < n; ++j) {
        it.eval(i, g, L0);
        it.add(i, g, L0);
        if (++g == ng) { g = 0; ++i; }
      }
    } else {
      it.eval(0, 0, L0);
      for (long j = 0; j < n; j += 2) {
        long i1 = i, g1 = g + 1;
        if (g1 == ng) { g1 = 0; ++i1; }
        if (j + 1 < n) it.eval(i1, g1, L1);
        it.add(i, g, L0);
        if (j + 1 >= n) break;
        long i2 = i1, g2 = g1 + 1;
        if (g2 == ng) { g2 = 0; ++i2; }
        if (j + 2 < n) it.eval(i2, g2, L0);
        it.add(i1, g1, L1);
        i = i2;
        g = g2;
      }
    }
    double* __restrict r = ore + row * A.nx + c0;
    double* __restrict m = oim + row * A.nx + c0;
    const PT* __restrict fr = ar[0];  // the groups' lanes in a row (the tile's pixels in order)
    const PT* __restrict fi = ai[0];
#pragma omp simd
    for (long c = 0; c < wv; ++c) {
      r[c] += static_cast<double>(fr[c]);
      m[c] += static_cast<double>(fi[c]);
    }
  }
}

// The range model's instance of a row (the series flag is the same for every tile of a call; a
// bistatic pair's series is the mean of its ends', so one instance serves both).
#define SARCLI_BY_MODEL(FN, ...)                       \
  do {                                                 \
    if (!A.series) FN<PT, K, ISA, 0>(__VA_ARGS__);     \
    else FN<PT, K, ISA, 1>(__VA_ARGS__);               \
  } while (0)

template <typename PT, int K, int ISA>
SARCLI_INLINE void bp_row(const Args& A, const PT* prof, long row, long p0, long p1,
                          Anchors& an, double* ore, double* oim) {
  SARCLI_BY_MODEL(bp_row_model, A, prof, row, p0, p1, an, ore, oim);
}

// Contraction: acc[2p], acc[2p + 1] += Σ over image row `row` of g · (pulse p's backprojection),
// for the pulses [p0, p1): the per-pulse derivative of an image functional with gradient g, as a
// gather from each profile where the adjoint (rp_pulse) scatters onto it.
template <typename PT, int K, int ISA, int SER>
SARCLI_INLINE void bp_contract_row_model(const Args& A, const PT* prof, const PT* gre, const PT* gim,
                                         long row, long p0, long p1, Anchors& an, double* acc) {
  const double y = A.y[row];
  float uf[kGroups][kLanes];
  double ud[kGroups][kLanes];
  PT wr[kGroups][kLanes], wi[kGroups][kLanes];
  Lanes<K> L;
  // each pulse's products summed lane by lane over the whole row, then across the lanes once: one
  // horizontal sum a pulse and row rather than one a pulse and tile
  PT* sums = reinterpret_cast<PT*>(an.sums.data());
  std::fill(sums, sums + 2 * kLanes * (p1 - p0), PT(0));
  for (long c0 = 0; c0 < A.nx; c0 += A.width) {
    double xc, he;
    const long wv = tile_lanes(A, c0, uf, ud, xc, he);
    const long ng = (wv + kLanes - 1) / kLanes;
    for (long c = 0; c < ng * kLanes; ++c) {  // lanes beyond the tile weigh nothing
      wr[c / kLanes][c % kLanes] = c < wv ? gre[row * A.nx + c0 + c] : PT(0);
      wi[c / kLanes][c % kLanes] = c < wv ? gim[row * A.nx + c0 + c] : PT(0);
    }
    anchors(A, p0, p1, xc, y, SER ? 0.0 : he, an);
    for (long p = p0; p < p1; ++p) {
      const Anchor a = an.get(p - p0);
      SeriesAnchor exv;
      if (SER) exv = an.series(p - p0);
      const SeriesAnchor* ex = &exv;
      const PT* pp = prof + 2 * p * A.lp;
      PT* __restrict sr = sums + 2 * kLanes * (p - p0);
      PT* __restrict si = sr + kLanes;
      for (long g = 0; g < ng; ++g) {
        PT ur[kLanes], ui[kLanes];
        carried_lanes<PT, K, ISA, SER>(a, ex, uf[g], ud[g], A.pad, pp, L, ur, ui);
        const PT* __restrict gr = wr[g];
        const PT* __restrict gi = wi[g];
#pragma omp simd
        for (int i = 0; i < kLanes; ++i) {
          sr[i] += gr[i] * ur[i] - gi[i] * ui[i];
          si[i] += gr[i] * ui[i] + gi[i] * ur[i];
        }
      }
    }
  }
  for (long p = p0; p < p1; ++p) {
    const PT* sr = sums + 2 * kLanes * (p - p0);
    double tr = 0.0, ti = 0.0;
    for (int i = 0; i < kLanes; ++i) {
      tr += static_cast<double>(sr[i]);
      ti += static_cast<double>(sr[kLanes + i]);
    }
    acc[2 * p] += tr;
    acc[2 * p + 1] += ti;
  }
}

template <typename PT, int K, int ISA>
SARCLI_INLINE void bp_contract_row(const Args& A, const PT* prof, const PT* gre, const PT* gim,
                                   long row, long p0, long p1, Anchors& an, double* acc) {
  SARCLI_BY_MODEL(bp_contract_row_model, A, prof, gre, gim, row, p0, p1, an, acc);
}

// Adjoint: every pixel of the image scattered onto pulse p's profile.
template <typename PT, int K, int ISA, int SER>
SARCLI_INLINE void rp_pulse_model(const Args& A, const PT* fre, const PT* fim, long p, PT* h) {
  float uf[kGroups][kLanes];
  double ud[kGroups][kLanes];
  Lanes<K> L;
  PT ur[kLanes], ui[kLanes];
  for (long row = 0; row < A.ny; ++row) {
    const double y = A.y[row];
    for (long c0 = 0; c0 < A.nx; c0 += A.width) {
      double xc, he;
      const long wt = tile_lanes(A, c0, uf, ud, xc, he);
      if (SER) he = 0.0;
      SeriesAnchor ex;
      const Anchor an = A.bist ? anchor<true, SER>(A, p, xc, y, he, ex) : anchor<false, SER>(A, p, xc, y, he, ex);
      for (long g = 0; g * kLanes < wt; ++g) {
        const long wv = std::min<long>(kLanes, wt - g * kLanes);
        eval_lanes<K, SER, ISA>(an, &ex, uf[g], ud[g], A.pad, L);
        const PT* fr = fre + row * A.nx + c0 + g * kLanes;
        const PT* fi = fim + row * A.nx + c0 + g * kLanes;
        for (long i = 0; i < wv; ++i) {  // f · exp(-i kc Δr) (masked)
          const PT c = L.c[i], s = L.s[i];
          ur[i] = fr[i] * c + fi[i] * s;
          ui[i] = fi[i] * c - fr[i] * s;
        }
        for (long i = 0; i < wv; ++i) {
          const int j = L.idx[i];
          for (int k = 0; k < Kernel<K>::taps; ++k) {
            const PT w = static_cast<PT>(L.w[k][i]);
            h[j + 2 * k] += w * ur[i];
            h[j + 2 * k + 1] += w * ui[i];
          }
        }
      }
    }
  }
}

template <typename PT, int K, int ISA>
SARCLI_INLINE void rp_pulse(const Args& A, const PT* fre, const PT* fim, long p, PT* h) {
  SARCLI_BY_MODEL(rp_pulse_model, A, fre, fim, p, h);
}
#undef SARCLI_BY_MODEL

// The SIMD-dispatched workers, one per instance and instruction set, picked per call. Explicit
// targets rather than SARCLI_CLONES: each copy uses the stencil loads of its own instruction set
// (Taps<..., ISA>), and $SARCLI_BP_ISA can cap the level so that tests and benchmarks run the
// AVX2 and baseline copies on an AVX-512 machine. (Hardware gathers, which the compiler emits
// under Intel tuning, measured 2 to 3 times slower than these loads on AMD Zen 5.)
#define SARCLI_BP_WORKER(PT, K, SUF, ATTR, ISA)                                                 \
  ATTR void bp_row_##SUF(const Args& A, const PT* prof, long row, long p0, long p1, Anchors& an, \
                         double* ore, double* oim) {                                            \
    bp_row<PT, K, ISA>(A, prof, row, p0, p1, an, ore, oim);                                     \
  }                                                                                             \
  ATTR void rp_pulse_##SUF(const Args& A, const PT* fre, const PT* fim, long p, PT* h) {        \
    rp_pulse<PT, K, ISA>(A, fre, fim, p, h);                                                         \
  }                                                                                             \
  ATTR void bp_contract_row_##SUF(const Args& A, const PT* prof, const PT* gre, const PT* gim,  \
                                  long row, long p0, long p1, Anchors& an, double* acc) {       \
    bp_contract_row<PT, K, ISA>(A, prof, gre, gim, row, p0, p1, an, acc);                       \
  }
// WORKER(PT, K, SUF, ATTR, ISA) for each precision and interpolator (SUF: f0 .. d4, then the
// instruction set's v4, v3 or v1), then for each instruction set: the tiled kernels' workers and
// the terrain kernels' (bp_points) alike, picked by SARCLI_PICK.
#define SARCLI_INSTANCES(WORKER, SUF, ATTR, ISA) \
  WORKER(float, 0, f0_##SUF, ATTR, ISA)          \
  WORKER(float, 1, f1_##SUF, ATTR, ISA)          \
  WORKER(float, 2, f2_##SUF, ATTR, ISA)          \
  WORKER(float, 4, f4_##SUF, ATTR, ISA)          \
  WORKER(double, 0, d0_##SUF, ATTR, ISA)         \
  WORKER(double, 1, d1_##SUF, ATTR, ISA)         \
  WORKER(double, 2, d2_##SUF, ATTR, ISA)         \
  WORKER(double, 4, d4_##SUF, ATTR, ISA)
#define SARCLI_ALL_ISAS(WORKER)                   \
  SARCLI_INSTANCES(WORKER, v4, SARCLI_BP_V4, 2)   \
  SARCLI_INSTANCES(WORKER, v3, SARCLI_BP_V3, 1)   \
  SARCLI_INSTANCES(WORKER, v1, , 0)
SARCLI_ALL_ISAS(SARCLI_BP_WORKER)
#undef SARCLI_BP_WORKER

}  // namespace

// 2: AVX-512, 1: AVX2 + FMA, 0: baseline x86-64 ($SARCLI_BP_ISA caps it, for tests and timing).
int isa_level() {
  int level = 0;
#if SARCLI_BP_DISPATCH
  __builtin_cpu_init();
  if (__builtin_cpu_supports("x86-64-v4")) level = 2;
  else if (__builtin_cpu_supports("x86-64-v3")) level = 1;
#endif
  if (const char* cap = std::getenv("SARCLI_BP_ISA")) level = std::min(level, std::atoi(cap));
  return level;
}

namespace {

template <typename PT>
using RowFn = void (*)(const Args&, const PT*, long, long, long, Anchors&, double*, double*);
template <typename PT>
using PulseFn = void (*)(const Args&, const PT*, const PT*, long, PT*);

// The worker NAME of precision P (f or d) for the interpolator `kind` (a profile kind) on
// instruction set `level`.
#define SARCLI_PICK_KIND(NAME, P, V)                                                      \
  (kind == 0 ? NAME##_##P##0_##V : kind == 1 ? NAME##_##P##1_##V : kind == 2 ? NAME##_##P##2_##V \
                                                                 : NAME##_##P##4_##V)
#define SARCLI_PICK(NAME, P)                                                      \
  (level == 2 ? SARCLI_PICK_KIND(NAME, P, v4) : level == 1 ? SARCLI_PICK_KIND(NAME, P, v3) \
                                                 : SARCLI_PICK_KIND(NAME, P, v1))
// The picker FN<PT>(kind) of function-pointer type TYPE<PT>: the worker NAME for float and double.
#define SARCLI_PICKER(TYPE, FN, NAME)                                                               \
  template <typename PT>                                                                            \
  TYPE<PT> FN(int kind);                                                                            \
  template <>                                                                                       \
  TYPE<float> FN<float>(int kind) { const int level = isa_level(); return SARCLI_PICK(NAME, f); }   \
  template <>                                                                                       \
  TYPE<double> FN<double>(int kind) { const int level = isa_level(); return SARCLI_PICK(NAME, d); }
template <typename PT>
using ContractFn = void (*)(const Args&, const PT*, const PT*, const PT*, long, long, long, Anchors&,
                            double*);
SARCLI_PICKER(RowFn, row_fn, bp_row)
SARCLI_PICKER(PulseFn, pulse_fn, rp_pulse)
SARCLI_PICKER(ContractFn, contract_fn, bp_contract_row)

Args make_args(in<double, 1> x, in<double, 1> y, in<double, 2> geo, long lp, long n_len, long pad,
               long width, bool bist, bool series) {
  Args A;
  A.x = x.data();
  A.y = y.data();
  A.geo = geo.data();
  A.nx = static_cast<long>(x.shape(0));
  A.ny = static_cast<long>(y.shape(0));
  A.B = static_cast<long>(geo.shape(1));
  A.lp = lp;
  A.n_len = n_len;
  A.pad = pad;
  A.width = width;
  A.half_len = static_cast<double>(n_len / 2);
  A.bist = bist;
  A.series = series;
  if (geo.shape(0) != kGeoRows) throw nb::value_error("backprojection: geo must have 11 rows");
  if (width < 1 || width > kLanes * kGroups)
    throw nb::value_error("backprojection: tile width must be 1..64");
  if (lp != n_len + 2 * pad || pad < 3) throw nb::value_error("backprojection: bad profile padding");
  if (A.nx < 1 || A.ny < 1) throw nb::value_error("backprojection: empty grid");
  return A;
}

}  // namespace

template <typename PT>
void bp_tiles(in<PT, 3> prof, in<double, 1> x, in<double, 1> y, in<double, 2> geo, long n_len,
              long pad, int kind, bool bist, long width, bool series, long block, out<double, 2> ore,
              out<double, 2> oim) {
  Args A = make_args(x, y, geo, static_cast<long>(prof.shape(1)), n_len, pad, width, bist, series);
  if (prof.shape(0) != static_cast<size_t>(A.B) || prof.shape(2) != 2 ||
      ore.shape(0) != static_cast<size_t>(A.ny) || ore.shape(1) != static_cast<size_t>(A.nx) ||
      oim.shape(0) != ore.shape(0) || oim.shape(1) != ore.shape(1) || !interp::profile_kind(kind))
    throw nb::value_error("bp_tiles: inconsistent shapes or options");
  const long nb_ = std::max<long>(1, block);
  const PT* pr = prof.data();
  double *o_r = ore.data(), *o_i = oim.data();
  const RowFn<PT> fn = row_fn<PT>(kind);
  nb::gil_scoped_release nogil;
#pragma omp parallel
  {
    Anchors an(static_cast<size_t>(nb_));
    // pulse blocks whose profiles stay in cache; every block gives each thread the same rows
    for (long p0 = 0; p0 < A.B; p0 += nb_) {
      const long p1 = std::min(A.B, p0 + nb_);
#pragma omp for schedule(static) nowait
      for (long row = 0; row < A.ny; ++row) fn(A, pr, row, p0, p1, an, o_r, o_i);
    }
  }
}

template <typename PT>
void rp_tiles(in<PT, 2> fre, in<PT, 2> fim, in<double, 1> x, in<double, 1> y, in<double, 2> geo,
              long n_len, long pad, int kind, bool bist, long width, bool series, out<PT, 3> h) {
  Args A = make_args(x, y, geo, static_cast<long>(h.shape(1)), n_len, pad, width, bist, series);
  if (h.shape(0) != static_cast<size_t>(A.B) || h.shape(2) != 2 ||
      fre.shape(0) != static_cast<size_t>(A.ny) || fre.shape(1) != static_cast<size_t>(A.nx) ||
      fim.shape(0) != fre.shape(0) || fim.shape(1) != fre.shape(1) || !interp::profile_kind(kind))
    throw nb::value_error("rp_tiles: inconsistent shapes or options");
  const PT *f_r = fre.data(), *f_i = fim.data();
  PT* hp = h.data();
  const PulseFn<PT> fn = pulse_fn<PT>(kind);
  nb::gil_scoped_release nogil;
#pragma omp parallel for schedule(static)
  for (long p = 0; p < A.B; ++p) fn(A, f_r, f_i, p, hp + 2 * p * A.lp);
}

template <typename PT>
void bp_contract(in<PT, 3> prof, in<PT, 2> gre, in<PT, 2> gim, in<double, 1> x, in<double, 1> y,
                 in<double, 2> geo, long n_len, long pad, int kind, bool bist, long width, bool series,
                 long block, out<double, 2> acc) {
  Args A = make_args(x, y, geo, static_cast<long>(prof.shape(1)), n_len, pad, width, bist, series);
  if (prof.shape(0) != static_cast<size_t>(A.B) || prof.shape(2) != 2 ||
      gre.shape(0) != static_cast<size_t>(A.ny) || gre.shape(1) != static_cast<size_t>(A.nx) ||
      gim.shape(0) != gre.shape(0) || gim.shape(1) != gre.shape(1) ||
      acc.shape(0) != static_cast<size_t>(A.B) || acc.shape(1) != 2 || !interp::profile_kind(kind))
    throw nb::value_error("bp_contract: inconsistent shapes or options");
  const long nb_ = std::max<long>(1, block);
  const PT* pr = prof.data();
  const PT *g_r = gre.data(), *g_i = gim.data();
  const ContractFn<PT> fn = contract_fn<PT>(kind);
  // one row of sums per image row, added in row order: the result does not depend on the threads
  std::vector<double> rows(static_cast<size_t>(A.ny) * 2 * A.B, 0.0);
  {
    nb::gil_scoped_release nogil;
#pragma omp parallel
    {
      Anchors an(static_cast<size_t>(nb_));
#pragma omp for schedule(static)
      for (long row = 0; row < A.ny; ++row)
        for (long p0 = 0; p0 < A.B; p0 += nb_)
          fn(A, pr, g_r, g_i, row, p0, std::min(A.B, p0 + nb_), an, rows.data() + row * 2 * A.B);
    }
  }
  double* o = acc.data();
  for (long k = 0; k < 2 * A.B; ++k) o[k] = 0.0;
  for (long row = 0; row < A.ny; ++row)
    for (long k = 0; k < 2 * A.B; ++k) o[k] += rows[row * 2 * A.B + k];
}

namespace {

// Backprojection onto pixels anywhere in 3-D (a map grid on terrain): no tiles, each pixel's
// differential range exact in float64, Δr = (|p|² - 2 a·p) / (|a - p| + |a|) + offset (and the
// mean of both ends when bistatic), then the same profile position, mask, interpolation weights
// and carrier as the tiled kernel (geo rows: PtGeo).

struct PointArgs {
  const double* pts;  // [N, 3]
  const double* geo;  // [kPtRows, B]
  long n, B, lp, n_len, pad;
  double half_len;
  bool bist;
};


// Lanes of pixels [i0, i0 + kLanes) for pulse q: first tap index, weights, masked carrier.
// (Loops over the lanes the compiler vectorises: the ranges in float64, then the profile position.)
template <int K>
SARCLI_INLINE void point_lanes(const PointArgs& A, long i0, long q, Lanes<K>& L) {
  const double* g = A.geo;
  const long B = A.B;
  const double ax = g[PAX * B + q], ay = g[PAY * B + q], az = g[PAZ * B + q], na = g[PNA * B + q];
  const double bx = g[PBX * B + q], by = g[PBY * B + q], bz = g[PBZ * B + q], nb = g[PNB * B + q];
  const double ib = g[PIB * B + q], kc = g[PKC * B + q], off = g[POFF * B + q];
  const double n_len = static_cast<double>(A.n_len);
  const long last = A.n - 1;
  double px[kLanes], py[kLanes], pz[kLanes], dr[kLanes];
  for (int i = 0; i < kLanes; ++i) {
    const double* p = A.pts + 3 * std::min(i0 + i, last);
    px[i] = p[0];
    py[i] = p[1];
    pz[i] = p[2];
  }
#pragma omp simd
  for (int i = 0; i < kLanes; ++i) {
    const double num = px[i] * (px[i] - 2.0 * ax) + py[i] * (py[i] - 2.0 * ay) + pz[i] * (pz[i] - 2.0 * az);
    const double dx = ax - px[i], dy = ay - py[i], dz = az - pz[i];
    dr[i] = num / (std::sqrt(dx * dx + dy * dy + dz * dz) + na);
  }
  if (A.bist) {
#pragma omp simd
    for (int i = 0; i < kLanes; ++i) {
      const double num = px[i] * (px[i] - 2.0 * bx) + py[i] * (py[i] - 2.0 * by) + pz[i] * (pz[i] - 2.0 * bz);
      const double dx = bx - px[i], dy = by - py[i], dz = bz - pz[i];
      dr[i] = 0.5 * (dr[i] + num / (std::sqrt(dx * dx + dy * dy + dz * dz) + nb));
    }
  }
  float t[kLanes], m[kLanes];
#pragma omp simd
  for (int i = 0; i < kLanes; ++i) {
    dr[i] += off;
    double sc = dr[i] * ib + A.half_len;
    m[i] = (sc >= 0.0 && sc < n_len && i0 + i <= last) ? 1.0f : 0.0f;
    sc = std::min(std::max(sc, 0.0), n_len - 1.0);
    const double fl = std::floor(sc);
    t[i] = static_cast<float>(sc - fl);
    L.idx[i] = 2 * (static_cast<int>(fl) + static_cast<int>(A.pad) - Kernel<K>::first);  // as Lanes::idx
  }
#pragma omp simd
  for (int i = 0; i < kLanes; ++i) {
    float c, s;
    carrier::cos_sin_f32(kc * dr[i], c, s);
    L.c[i] = m[i] * c;
    L.s[i] = m[i] * s;
  }
  Kernel<K>::weights(t, L.w);
}

// One group of kLanes pixels over every pulse (forward), and one pulse over every pixel (adjoint).
template <typename PT, int K, int ISA>
SARCLI_INLINE void bp_points_group(const PointArgs& A, const PT* prof, long i0, double* ore, double* oim) {
  Lanes<K> L;
  PT ar[kLanes] = {}, ai[kLanes] = {};
  for (long q = 0; q < A.B; ++q) {
    point_lanes<K>(A, i0, q, L);
    PT tp[2 * Kernel<K>::taps][kLanes];
    Taps<PT, Kernel<K>::taps, ISA>::load(prof + 2 * q * A.lp, L.idx, tp);
#pragma omp simd
    for (int i = 0; i < kLanes; ++i) {
      PT vr = 0, vi = 0;
      for (int k = 0; k < Kernel<K>::taps; ++k) {
        vr += static_cast<PT>(L.w[k][i]) * tp[2 * k][i];
        vi += static_cast<PT>(L.w[k][i]) * tp[2 * k + 1][i];
      }
      ar[i] += vr * L.c[i] - vi * L.s[i];
      ai[i] += vr * L.s[i] + vi * L.c[i];
    }
  }
  for (int i = 0; i < kLanes && i0 + i < A.n; ++i) {
    ore[i0 + i] += static_cast<double>(ar[i]);
    oim[i0 + i] += static_cast<double>(ai[i]);
  }
}

template <typename PT, int K, int ISA>
SARCLI_INLINE void rp_points_pulse(const PointArgs& A, const PT* fre, const PT* fim, long q, PT* h) {
  Lanes<K> L;
  PT* hq = h + 2 * q * A.lp;
  for (long i0 = 0; i0 < A.n; i0 += kLanes) {
    point_lanes<K>(A, i0, q, L);
    for (int i = 0; i < kLanes && i0 + i < A.n; ++i) {  // f · exp(-i kc Δr) (masked)
      const PT c = L.c[i], s = L.s[i], fr = fre[i0 + i], fi = fim[i0 + i];
      const PT ur = fr * c + fi * s, ui = fi * c - fr * s;
      const int j = L.idx[i];  // 2 x the first tap's bin
      for (int k = 0; k < Kernel<K>::taps; ++k) {
        const PT w = static_cast<PT>(L.w[k][i]);
        hq[j + 2 * k] += w * ur;
        hq[j + 2 * k + 1] += w * ui;
      }
    }
  }
}

// Workers per precision, interpolator and instruction set, as the tiled kernel's.
#define SARCLI_PT_WORKER(PT, K, SUF, ATTR, ISA)                                                       \
  ATTR void bp_points_##SUF(const PointArgs& A, const PT* prof, long i0, double* ore, double* oim) { \
    bp_points_group<PT, K, ISA>(A, prof, i0, ore, oim);                                              \
  }                                                                                                   \
  ATTR void rp_points_##SUF(const PointArgs& A, const PT* fre, const PT* fim, long q, PT* h) {       \
    rp_points_pulse<PT, K, ISA>(A, fre, fim, q, h);                                                  \
  }
SARCLI_ALL_ISAS(SARCLI_PT_WORKER)
#undef SARCLI_PT_WORKER
#undef SARCLI_ALL_ISAS
#undef SARCLI_INSTANCES

template <typename PT>
using PointFn = void (*)(const PointArgs&, const PT*, long, double*, double*);
template <typename PT>
using PointAdjFn = void (*)(const PointArgs&, const PT*, const PT*, long, PT*);
SARCLI_PICKER(PointFn, point_fn, bp_points)
SARCLI_PICKER(PointAdjFn, point_adj_fn, rp_points)
#undef SARCLI_PICKER
#undef SARCLI_PICK
#undef SARCLI_PICK_KIND

PointArgs point_args(in<double, 2> pts, in<double, 2> geo, long lp, long n_len, long pad, bool bist, int kind,
                     const char* name) {
  if (pts.shape(1) != 3 || geo.shape(0) != kPtRows || !interp::profile_kind(kind) ||
      n_len < 2 || pad < 3 || lp != n_len + 2 * pad)
    throw nb::value_error((std::string(name) + ": inconsistent shapes or options").c_str());
  PointArgs A;
  A.pts = pts.data();
  A.geo = geo.data();
  A.n = static_cast<long>(pts.shape(0));
  A.B = static_cast<long>(geo.shape(1));
  A.lp = lp;
  A.n_len = n_len;
  A.pad = pad;
  A.half_len = static_cast<double>(n_len / 2);
  A.bist = bist;
  return A;
}

}  // namespace

template <typename PT>
void bp_points(in<PT, 3> prof, in<double, 2> pts, in<double, 2> geo, long n_len, long pad, int kind, bool bist,
               out<double, 1> ore, out<double, 1> oim) {
  const PointArgs A = point_args(pts, geo, static_cast<long>(prof.shape(1)), n_len, pad, bist, kind, "bp_points");
  if (prof.shape(0) != static_cast<size_t>(A.B) || prof.shape(2) != 2 ||
      ore.shape(0) != static_cast<size_t>(A.n) || oim.shape(0) != static_cast<size_t>(A.n))
    throw nb::value_error("bp_points: inconsistent shapes or options");
  const PT* pr = prof.data();
  double *o_r = ore.data(), *o_i = oim.data();
  const PointFn<PT> fn = point_fn<PT>(kind);
  const long groups = (A.n + kLanes - 1) / kLanes;
  nb::gil_scoped_release nogil;
#pragma omp parallel for schedule(static)
  for (long gi = 0; gi < groups; ++gi) fn(A, pr, gi * kLanes, o_r, o_i);
}

template <typename PT>
void rp_points(in<PT, 1> fre, in<PT, 1> fim, in<double, 2> pts, in<double, 2> geo, long n_len, long pad, int kind,
               bool bist, out<PT, 3> h) {
  const PointArgs A = point_args(pts, geo, static_cast<long>(h.shape(1)), n_len, pad, bist, kind, "rp_points");
  if (h.shape(0) != static_cast<size_t>(A.B) || h.shape(2) != 2 || fre.shape(0) != static_cast<size_t>(A.n) ||
      fim.shape(0) != static_cast<size_t>(A.n))
    throw nb::value_error("rp_points: inconsistent shapes or options");
  const PT *f_r = fre.data(), *f_i = fim.data();
  PT* hp = h.data();
  const PointAdjFn<PT> fn = point_adj_fn<PT>(kind);
  nb::gil_scoped_release nogil;
#pragma omp parallel for schedule(static)
  for (long q = 0; q < A.B; ++q) fn(A, f_r, f_i, q, hp);
}

namespace {

// The carrier of phases ph[0 .. n) and the weights of fractions t[0 .. n) in groups of kLanes
// lanes (Kernel<K>::weights, as the kernels call it), on the SIMD copy this CPU runs.
SARCLI_CLONES
void carrier_run(const double* ph, std::size_t n, float* c, float* s) {
  for (std::size_t i = 0; i < n; ++i) carrier::cos_sin_f32(ph[i], c[i], s[i]);
}

SARCLI_CLONES
void carrier_turns_run(const double* q, std::size_t n, float* c, float* s) {
  for (std::size_t i = 0; i < n; ++i) carrier::cos_sin_turns_f32(q[i], c[i], s[i]);
}

SARCLI_CLONES
void weight_groups(const float* t, std::size_t n, int kind, float* w) {
  const std::size_t taps = interp::kTaps[kind];
  for (std::size_t i0 = 0; i0 < n; i0 += kLanes) {
    float tl[kLanes] = {}, wl[6][kLanes];
    for (std::size_t i = 0; i < kLanes && i0 + i < n; ++i) tl[i] = t[i0 + i];
    if (kind == interp::kLinear) Kernel<interp::kLinear>::weights(tl, wl);
    else if (kind == interp::kKeysCubic) Kernel<interp::kKeysCubic>::weights(tl, wl);
    else if (kind == interp::kLagrange3) Kernel<interp::kLagrange3>::weights(tl, wl);
    else Kernel<interp::kLanczos3>::weights(tl, wl);
    for (std::size_t i = 0; i < kLanes && i0 + i < n; ++i)
      for (std::size_t k = 0; k < taps; ++k) w[(i0 + i) * taps + k] = wl[k][i];
  }
}

}  // namespace

// The carrier and interpolation weights as the kernels evaluate them (for tests).
void carrier_values(in<double, 1> ph, out<float, 1> c, out<float, 1> s) {
  const size_t n = ph.shape(0);
  if (c.shape(0) != n || s.shape(0) != n) throw nb::value_error("carrier_values: shapes");
  carrier_run(ph.data(), n, c.data(), s.data());
}

void carrier_turn_values(in<double, 1> q, out<float, 1> c, out<float, 1> s) {
  const size_t n = q.shape(0);
  if (c.shape(0) != n || s.shape(0) != n) throw nb::value_error("carrier_turn_values: shapes");
  carrier_turns_run(q.data(), n, c.data(), s.data());
}

void weight_values(in<float, 1> t, int kind, out<float, 2> w) {
  const size_t n = t.shape(0);
  if (!interp::profile_kind(kind) || w.shape(0) != n ||
      w.shape(1) != static_cast<size_t>(interp::kTaps[kind]))
    throw nb::value_error("weight_values: shapes");
  weight_groups(t.data(), n, kind, w.data());
}

template void bp_tiles<float>(in<float, 3>, in<double, 1>, in<double, 1>, in<double, 2>, long, long, int, bool, long,
                              bool, long, out<double, 2>, out<double, 2>);
template void bp_tiles<double>(in<double, 3>, in<double, 1>, in<double, 1>, in<double, 2>, long, long, int, bool, long,
                               bool, long, out<double, 2>, out<double, 2>);
template void rp_tiles<float>(in<float, 2>, in<float, 2>, in<double, 1>, in<double, 1>, in<double, 2>, long, long, int,
                              bool, long, bool, out<float, 3>);
template void rp_tiles<double>(in<double, 2>, in<double, 2>, in<double, 1>, in<double, 1>, in<double, 2>, long, long,
                               int, bool, long, bool, out<double, 3>);
template void bp_contract<float>(in<float, 3>, in<float, 2>, in<float, 2>, in<double, 1>, in<double, 1>, in<double, 2>,
                                 long, long, int, bool, long, bool, long, out<double, 2>);
template void bp_contract<double>(in<double, 3>, in<double, 2>, in<double, 2>, in<double, 1>, in<double, 1>,
                                  in<double, 2>, long, long, int, bool, long, bool, long, out<double, 2>);
template void bp_points<float>(in<float, 3>, in<double, 2>, in<double, 2>, long, long, int, bool, out<double, 1>,
                               out<double, 1>);
template void bp_points<double>(in<double, 3>, in<double, 2>, in<double, 2>, long, long, int, bool, out<double, 1>,
                                out<double, 1>);
template void rp_points<float>(in<float, 1>, in<float, 1>, in<double, 2>, in<double, 2>, long, long, int, bool,
                               out<float, 3>);
template void rp_points<double>(in<double, 1>, in<double, 1>, in<double, 2>, in<double, 2>, long, long, int, bool,
                                out<double, 3>);

}  // namespace sarcli
