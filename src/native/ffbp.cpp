// Fast factorised backprojection (sarcli.formers.ffbp): stage 0 (pulses onto each base
// sub-aperture's polar grid), the merges (children's polar grids onto their parent's), the final
// stage (the last polar grids onto the Cartesian image) and the deapodized tone weights.
//
// A sub-aperture's polar grid is described by a frame column (rows, kFrameRows): its centre c
// (cx, cy, cz, |c|), the ground distance ρ0 of c's nadir from the scene origin, the unit vector
// e0 from that nadir towards the origin, and the grid's origin and spacing (q0, u0, Δu; Δq is
// shared by all grids). A ground point x has the coordinates q = |c − x| − |c| and
// u = ((x − c)·e⊥)/|c − x| (e⊥ = ẑ × e0), both formed without cancellation. Sub-images are stored
// demodulated, F(q, u) = I(x) e^{−i k_ref q}, as float32 real and imaginary planes [n, nu, nq].
#include <algorithm>
#include <complex>
#include <cmath>
#include <cstdint>
#include <string>
#include <type_traits>
#include <vector>

#include <omp.h>

#include "numerics/keys.hpp"
#include "numerics/kinds.hpp"
#include "numerics/lanczos.hpp"
#include "numerics/sincos.hpp"
#include "ffbp.hpp"
#include "sarcli_simd.hpp"

namespace sarcli {
namespace {

using i32 = std::int32_t;
// a lambda compiled into the (cloned) function that calls it
#define SARCLI_LAMBDA_INLINE __attribute__((always_inline))
using i64 = std::int64_t;
using u32 = std::uint32_t;

using interp::kTaps;   // taps of each interpolation kernel (numerics/kinds.hpp)
struct Frame {
  double cx, cy, cn, rho0, e0x, e0y, cz, q0, u0, du;
};

SARCLI_INLINE Frame frame_at(const double* f, std::size_t n, std::size_t s) {
  return {f[kCx * n + s],   f[kCy * n + s], f[kCn * n + s], f[kRho0 * n + s], f[kE0x * n + s],
          f[kE0y * n + s],  f[kCz * n + s], f[kQ0 * n + s], f[kU0 * n + s],   f[kDu * n + s]};
}

// (q, u) of the ground point (x, y, 0) about the frame's centre. With s = |c − x| = √(|c|² + num),
// q = num/(s + |c|) and u = (e⊥·x)/s. The reciprocals 1/s and 1/(s + |c|) start from float32
// (a square root and a division of sixteen lanes a vector) and take two Newton steps in float64
// each (relative error 1e-7, then 1e-14, then rounding): a float64 square root and division
// of eight lanes cost several times more, and the final stage takes (q, u) of every pixel in
// every sub-image.
SARCLI_INLINE void coords(double x, double y, const Frame& g, double& q, double& u) {
  const double num = x * x + y * y - 2.0 * (g.cx * x + g.cy * y);
  const double r2 = g.cn * g.cn + num;
  double r = static_cast<double>(1.0f / std::sqrt(static_cast<float>(r2)));   // 1/s
  r = r * (1.5 - 0.5 * r2 * r * r);
  r = r * (1.5 - 0.5 * r2 * r * r);
  const double t = r2 * r + g.cn;   // s + |c|
  double it = static_cast<double>(1.0f / static_cast<float>(t));
  it = it * (2.0 - t * it);
  it = it * (2.0 - t * it);
  q = num * it;
  u = (g.e0x * y - g.e0y * x) * r;
}

// Ground point (x, y) of the polar node (q, u): the inverse of coords. With R = |c| + q the
// point lies uR across the line from the nadir to the origin and a = √(ρ0² + g − (uR)²) along it
// (g = q(2|c| + q)); its offset a − ρ0 = (g − (uR)²)/(a + ρ0) is formed without cancellation.
SARCLI_INLINE void node(double q, double u, const Frame& f, double& x, double& y) {
  const double g = q * (2.0 * f.cn + q);
  const double across = u * (f.cn + q);
  const double a2 = g - across * across;
  const double along = a2 / (std::sqrt(f.rho0 * f.rho0 + a2) + f.rho0);
  x = along * f.e0x - across * f.e0y;
  y = along * f.e0y + across * f.e0x;
}

// |a − x| − |a| for a ground point, cancellation-free.
SARCLI_INLINE double one_way(double x, double y, double ax, double ay, double a2, double na) {
  const double num = x * x + y * y - 2.0 * (ax * x + ay * y);
  return num / (std::sqrt(a2 + num) + na);
}

// Stencil start of fractional index f (clamped so every access stays in [0, n)), its fraction,
// and whether the whole stencil lies inside. The start is formed in floating point and converted
// once to int32 (a vector conversion on AVX2 too). A NaN index (a polar node that is no ground
// point: near the radar a grid's corners at large |u| and small q can lie below the ground) is
// outside, at start 0 and fraction 0.
SARCLI_INLINE i32 locate(double f, double lo, double n, double ntap, double& frac, bool& ok) {
  const double fl = std::floor(f);
  const double s = fl + lo;
  ok = (s >= 0.0) & (s + ntap <= n);
  frac = f == f ? f - fl : 0.0;
  return static_cast<i32>(std::min(std::max(0.0, s), n - ntap));   // std::max(0, NaN) is 0
}

// Each row's bounds [start, stop) within [0, nq].
void check_rows(const i64* rows, std::size_t n_rows, std::size_t nq, const char* who) {
  for (std::size_t r = 0; r < n_rows; ++r)
    if (rows[2 * r] < 0 || rows[2 * r + 1] < rows[2 * r] || static_cast<std::size_t>(rows[2 * r + 1]) > nq)
      throw nb::value_error((std::string(who) + ": row bounds out of range").c_str());
}

// ---- interpolation weights ---------------------------------------------------------------------

template <typename T>
SARCLI_INLINE T poly7(const T* c, T x) {
  return ((((((c[7] * x + c[6]) * x + c[5]) * x + c[4]) * x + c[3]) * x + c[2]) * x + c[1]) * x + c[0];
}

// Lanczos-3 weights at offsets −2 .. 3 (numerics/lanczos.hpp: float32, rounded to T).
template <typename T>
SARCLI_INLINE void lanczos(T t, T* w) {
  float v[6];
  interp::lanczos3(static_cast<float>(t), v);
  for (int j = 0; j < 6; ++j) w[j] = static_cast<T>(v[j]);
}

// w[tap * stride + i]: the weights of every fraction of a row. Kind 3: polynomials of degree 7
// in 2·frac − 1 (tab[tap][8], sarcli.formers.ffbp_model.optimal_kernel), evaluated tap by tap so
// the loop over the row vectorises (float32: sixteen lanes a vector on AVX-512).
template <typename T>
SARCLI_INLINE void row_weights(int kind, const T* frac, std::size_t n, T* w, std::size_t stride, const T* tab) {
  if (kind == interp::kPoly6) {
    for (int j = 0; j < 6; ++j) {
      const T* c = tab + 8 * j;
      T* wj = w + j * stride;
      for (std::size_t i = 0; i < n; ++i) wj[i] = poly7(c, T(2) * frac[i] - T(1));
    }
  } else if (kind == interp::kLinear) {
    for (std::size_t i = 0; i < n; ++i) { w[i] = T(1) - frac[i]; w[stride + i] = frac[i]; }
  } else if (kind == interp::kKeysCubic) {
#pragma omp simd
    for (std::size_t i = 0; i < n; ++i) interp::keys(frac[i], w + i, stride);
  } else if (kind == interp::kLagrange3) {
#pragma omp simd
    for (std::size_t i = 0; i < n; ++i) interp::lagrange(frac[i], w + i, stride);
  } else {
    T v[6] = {};
    for (std::size_t i = 0; i < n; ++i) {
      lanczos(frac[i], v);
      for (int j = 0; j < 6; ++j) w[j * stride + i] = v[j];
    }
  }
}

// ---- stage 0 -----------------------------------------------------------------------------------

// √(1 + e) − 1 by eight terms of its binomial series (Horner), C_k = binom(1/2, k).
SARCLI_INLINE double sqrt_series(double e) {
  constexpr double c1 = 0.5, c2 = -0.125, c3 = 0.0625, c4 = -0.0390625, c5 = 0.02734375,
                   c6 = -0.0205078125, c7 = 0.01611328125, c8 = -0.013092041015625;
  return e * (c1 + e * (c2 + e * (c3 + e * (c4 + e * (c5 + e * (c6 + e * (c7 + e * c8)))))));
}

struct Stage0 {
  const float *pre, *pim;   // profiles [B, plen]
  std::size_t plen;
  const i64 *first, *count;
  const double* pul;        // [kPulseRows, B]
  std::size_t B;
  const bool* series;
  const double* frame;      // [kFrameRows, S]
  std::size_t S, nt, nq;
  const float* tab;
  int kind, wmode;          // wmode: WeightMode of the 6-tap kernels
  bool weights_first;       // the 6-tap weights in a pass before the blocks (stage0_weights_first)
  bool bistatic;
  double half_len, n_len, off, dq, kref;
  float *out_re, *out_im;
  const i64* rows;          // [S, nt, 2]: the nodes start .. stop-1 of each row that are formed
};

// Stage 0 takes its nodes in blocks of kBlock0 (one AVX-512 vector of float32) and models range
// and phase along a row over tiles of about kTile0 nodes (stage0_row).
constexpr std::size_t kBlock0 = 16, kTile0 = 32;
// Largest phase (radians) and profile position (bins) a tile's quadratic model may miss by at the
// check points before its nodes are evaluated exactly.
constexpr double kFitPhase = 1e-6, kFitBin = 1e-5;

// The reciprocals of a tile of n nodes' divided differences (fit_from): 1/jm, 1/je, 1/(je − jm),
// worked out once a row rather than once a pulse.
struct TileInv {
  double m, e, d;
};

SARCLI_INLINE TileInv tile_inv(std::size_t n) {
  const double jm = static_cast<double>((n - 1) / 2), je = static_cast<double>(n - 1);
  return {1.0 / jm, 1.0 / je, 1.0 / (je - jm)};
}

// A tile's model of a node's profile position (relative to the whole bin jb) and demodulated
// carrier phase ψ = k_c Δr − k_ref q (reduced to [−π, π] at the tile's middle node jm): the
// quadratics through its first, middle and last nodes, in the node's offset j from the first,
// taken about the middle so that float32 rounds them at half a tile's reach, not a whole one's.
struct TileFit {
  double jb, p0, p1, p2, s0, s1, s2, jm;
  SARCLI_INLINE double pos(double j) const { return p0 + (j - jm) * (p1 + j * p2); }
  SARCLI_INLINE double psi(double j) const { return s0 + (j - jm) * (s1 + j * s2); }
};

// The quadratics of a tile from its first, middle and last nodes' profile positions pv and phases
// sv (jm: the middle node's offset).
SARCLI_INLINE TileFit fit_from(const double* pv, const double* sv, double jm, const TileInv& inv) {
  TileFit f;   // Newton's form on the nodes jm, 0, je
  f.jm = jm;
  f.jb = std::floor(pv[1]);
  constexpr double tw = 6.283185307179586, inv_tw = 0.15915494309189535;
  f.p0 = pv[1] - f.jb;
  f.p1 = (pv[1] - pv[0]) * inv.m;
  f.p2 = ((pv[2] - pv[0]) * inv.e - f.p1) * inv.d;
  f.s0 = sv[1] - std::nearbyint(sv[1] * inv_tw) * tw;
  f.s1 = (sv[1] - sv[0]) * inv.m;
  f.s2 = ((sv[2] - sv[0]) * inv.e - f.s1) * inv.d;
  return f;
}


struct Scratch0 {
  std::vector<double> xs, ys, ax, ay, az, ir2, rr, qq, xpos, xpsi;   // xpos, xpsi: an exact tile's positions and phases
  std::vector<i32> idx;
  std::vector<float> frac, cr, ci, w, acc_re, acc_im;
  std::vector<unsigned char> exact;   // per tile: evaluate every node exactly
  std::vector<TileInv> inv;           // per tile: tile_inv
  // every tile's three fit nodes (3t, 3t + 1, 3t + 2: its first, middle and last), their node
  // arrays gathered once a row, and one pulse's exact ranges there
  std::vector<double> fxs, fys, fax, fay, faz, fir2, frr, fqq, fd;
  // every tile's two check nodes (2t, 2t + 1), their offsets in the tile and one pulse's exact
  // ranges there
  std::vector<double> cxs, cys, cax, cay, caz, cir2, crr, cqq, cj, cd;
  std::vector<TileFit> fit;           // per tile: one pulse's quadratics
  std::size_t n;                        // nodes rounded up to whole blocks
  explicit Scratch0(std::size_t nq)
      : xs(nq), ys(nq), ax(nq), ay(nq), az(nq), ir2(nq), rr(nq), qq(nq), xpos(nq), xpsi(nq),
        idx((nq + kBlock0 - 1) / kBlock0 * kBlock0 + kBlock0), frac(idx.size()), cr(idx.size()), ci(idx.size()),
        w(6 * idx.size()), acc_re(idx.size()), acc_im(idx.size()), exact(nq / kTile0 + 1), inv(nq / kTile0 + 1),
        fxs(3 * inv.size()), fys(fxs.size()), fax(fxs.size()), fay(fxs.size()), faz(fxs.size()), fir2(fxs.size()),
        frr(fxs.size()), fqq(fxs.size()), fd(fxs.size()), cxs(2 * inv.size()), cys(cxs.size()), cax(cxs.size()),
        cay(cxs.size()), caz(cxs.size()), cir2(cxs.size()), crr(cxs.size()), cqq(cxs.size()), cj(cxs.size()),
        cd(cxs.size()), fit(inv.size()), n(idx.size() - kBlock0) {}
};

// How weights6 forms the six weights of a 6-tap kernel: read precomputed ones, evaluate the
// polynomials, or evaluate the polynomials of a symmetric kernel (w_{5−b}(x) = w_b(−x)) as their
// even and odd parts, which gives two weights for little more than the price of one.
enum WeightMode { kWeightsRead = 0, kWeightsPoly = 1, kWeightsSymmetric = 2 };

// Whether the polynomials tab[6][8] (in x = 2·frac − 1) are a symmetric kernel's: tab[5 − b][k] =
// (−1)^k tab[b][k] (the optimal and deapodized kernels are, to rounding).
inline bool symmetric6(const float* tab) {
  float top = 0.0f;
  for (int i = 0; i < 48; ++i) top = std::max(top, std::abs(tab[i]));
  for (int b = 0; b < 3; ++b)
    for (int k = 0; k < 8; ++k)
      if (std::abs(tab[8 * (5 - b) + k] - ((k & 1) ? -tab[8 * b + k] : tab[8 * b + k])) > 1e-6f * top) return false;
  return true;
}

inline int weight_mode(int kind, const float* tab) {
  return kind != interp::kPoly6 ? kWeightsRead : symmetric6(tab) ? kWeightsSymmetric : kWeightsPoly;
}

// f(std::integral_constant<int, mode>{}): a kernel instantiated for each weight mode.
template <typename F>
SARCLI_INLINE void by_mode(int mode, F&& f) {
  if (mode == kWeightsSymmetric) f(std::integral_constant<int, kWeightsSymmetric>{});
  else if (mode == kWeightsPoly) f(std::integral_constant<int, kWeightsPoly>{});
  else f(std::integral_constant<int, kWeightsRead>{});
}

// The six weights of a 6-tap kernel at fraction index k: the polynomials of tab ([6][8], degree 7
// in 2·frac − 1) evaluated in place, or read from w[tap * ws + k] (WeightMode).
template <int Mode>
SARCLI_INLINE void weights6(const float* frac, const float* tab, const float* w, std::size_t ws, std::size_t k,
                            float& v0, float& v1, float& v2, float& v3, float& v4, float& v5) {
  if constexpr (Mode == kWeightsSymmetric) {
    const float x = 2.0f * frac[k] - 1.0f, y = x * x;
    const float* c = tab;
    const float e0 = ((c[6] * y + c[4]) * y + c[2]) * y + c[0], o0 = (((c[7] * y + c[5]) * y + c[3]) * y + c[1]) * x;
    c = tab + 8;
    const float e1 = ((c[6] * y + c[4]) * y + c[2]) * y + c[0], o1 = (((c[7] * y + c[5]) * y + c[3]) * y + c[1]) * x;
    c = tab + 16;
    const float e2 = ((c[6] * y + c[4]) * y + c[2]) * y + c[0], o2 = (((c[7] * y + c[5]) * y + c[3]) * y + c[1]) * x;
    v0 = e0 + o0;
    v5 = e0 - o0;
    v1 = e1 + o1;
    v4 = e1 - o1;
    v2 = e2 + o2;
    v3 = e2 - o2;
  } else if constexpr (Mode == kWeightsPoly) {
    const float x = 2.0f * frac[k] - 1.0f;
    v0 = poly7(tab, x);
    v1 = poly7(tab + 8, x);
    v2 = poly7(tab + 16, x);
    v3 = poly7(tab + 24, x);
    v4 = poly7(tab + 32, x);
    v5 = poly7(tab + 40, x);
  } else {
    v0 = w[k];
    v1 = w[ws + k];
    v2 = w[2 * ws + k];
    v3 = w[3 * ws + k];
    v4 = w[4 * ws + k];
    v5 = w[5 * ws + k];
  }
}

// The six weights w[b * ws + k] of a 6-tap kernel at fractions frac[0 .. n) (weights6; Mode not
// kWeightsRead), in one vectorised pass: the polynomials' coefficients are broadcast once for the
// pass, where a loop forming them block by block broadcasts them again for every block.
template <int Mode>
SARCLI_INLINE void weights6_pass(const float* __restrict frac, const float* __restrict tab, std::size_t n,
                                 float* __restrict w, std::size_t ws) {
#pragma omp simd
  for (std::size_t k = 0; k < n; ++k) {
    float v0, v1, v2, v3, v4, v5;
    weights6<Mode>(frac, tab, nullptr, 0, k, v0, v1, v2, v3, v4, v5);
    w[k] = v0;
    w[ws + k] = v1;
    w[2 * ws + k] = v2;
    w[3 * ws + k] = v3;
    w[4 * ws + k] = v4;
    w[5 * ws + k] = v5;
  }
}

// acc[k] += (cr + i ci)[k] Σ_b w_b[k] src[k + off + b] for k in [k0, k1): a run of points whose
// stencils start at consecutive samples (contiguous loads), float32 throughout; the weights are
// formed in the same pass (weights6).
template <int Mode>
SARCLI_INLINE void tap6_run(const float* sre, const float* sim, std::ptrdiff_t off, const float* frac,
                            const float* tab, const float* w, std::size_t ws, const float* cr, const float* ci,
                            float* acc_re, float* acc_im, std::size_t k0, std::size_t k1) {
  const float *r = sre + off, *m = sim + off;
#pragma omp simd
  for (std::size_t k = k0; k < k1; ++k) {
    float v0, v1, v2, v3, v4, v5;
    weights6<Mode>(frac, tab, w, ws, k, v0, v1, v2, v3, v4, v5);
    const float vr = v0 * r[k] + v1 * r[k + 1] + v2 * r[k + 2] + v3 * r[k + 3] + v4 * r[k + 4] + v5 * r[k + 5];
    const float vi = v0 * m[k] + v1 * m[k + 1] + v2 * m[k + 2] + v3 * m[k + 3] + v4 * m[k + 4] + v5 * m[k + 5];
    acc_re[k] += vr * cr[k] - vi * ci[k];
    acc_im[k] += vr * ci[k] + vi * cr[k];
  }
}

// tap6_run for points whose stencils start anywhere (src + idx[k]): gathers.
template <int Mode>
SARCLI_INLINE void tap6_gather(const float* sre, const float* sim, const i32* idx, const float* frac,
                               const float* tab, const float* w, std::size_t ws, const float* cr, const float* ci,
                               float* acc_re, float* acc_im, std::size_t n) {
  for (std::size_t k = 0; k < n; ++k) {
    float v0, v1, v2, v3, v4, v5;
    weights6<Mode>(frac, tab, w, ws, k, v0, v1, v2, v3, v4, v5);
    const float *r = sre + idx[k], *m = sim + idx[k];
    const float vr = v0 * r[0] + v1 * r[1] + v2 * r[2] + v3 * r[3] + v4 * r[4] + v5 * r[5];
    const float vi = v0 * m[0] + v1 * m[1] + v2 * m[2] + v3 * m[3] + v4 * m[4] + v5 * m[5];
    acc_re[k] += vr * cr[k] - vi * ci[k];
    acc_im[k] += vr * ci[k] + vi * cr[k];
  }
}

// The points k in (k0, k1) where idx[k] − idx[k − 1] differs from step, listed in brk (returns how
// many). Such breaks come one to a few a row (where the points' spacing drifts from the samples'),
// so a block of 16 points without one is passed over after one vectorised test, and the others are
// listed without branches.
SARCLI_INLINE std::size_t list_breaks(const i32* idx, std::size_t k0, std::size_t k1, i32 step, i32* brk) {
  std::size_t nb = 0, k = k0 + 1;
  for (; k + 16 <= k1; k += 16) {
    i32 any = 0;
#pragma omp simd reduction(| : any)
    for (std::size_t i = k; i < k + 16; ++i) any |= (idx[i] - idx[i - 1]) ^ step;
    if (any == 0) continue;
    for (std::size_t i = k; i < k + 16; ++i) {
      brk[nb] = static_cast<i32>(i);
      nb += static_cast<std::size_t>(idx[i] - idx[i - 1] != step);
    }
  }
  for (; k < k1; ++k) {
    brk[nb] = static_cast<i32>(k);
    nb += static_cast<std::size_t>(idx[k] - idx[k - 1] != step);
  }
  return nb;
}

// Runs of points k whose stencil start idx[k] − k is constant (idx increasing by one a point):
// calls run(k0, k1, off) for each, and returns false without calling when there are more than
// max_runs (the points are better served by gathers). The run boundaries are listed first
// (list_breaks; brk: k1 − k0 entries of scratch).
template <typename Run>
SARCLI_INLINE bool for_runs(const i32* idx, std::size_t k0, std::size_t k1, std::size_t max_runs, i32* brk,
                            Run run) {
  const std::size_t nb = list_breaks(idx, k0, k1, 1, brk);
  if (nb + 1 > max_runs) return false;
  std::size_t i = k0;
  for (std::size_t b = 0; b <= nb; ++b) {
    const std::size_t e = b < nb ? static_cast<std::size_t>(brk[b]) : k1;
    if (e > i) run(i, e, static_cast<std::ptrdiff_t>(idx[i]) - static_cast<std::ptrdiff_t>(i));
    i = e;
  }
  return true;
}

// A row's node arrays as exact_dr reads them: ground points (xs, ys) and the series' factors.
struct NodeGeo {
  const double *xs, *ys, *ax, *ay, *az, *ir2, *rr, *qq;
};

// Exact differential range of pulse g (row r of the pulse table at g[r * B]) at node iq of N: the
// series about the sub-aperture centre or the square root (stage 0's two forms), monostatic or
// bistatic; the forms as template arguments, so that a loop over the nodes has no branch in it.
template <bool Series, bool Bistatic>
SARCLI_INLINE double exact_dr_of(const double* g, std::size_t B, const NodeGeo& N, std::size_t iq) {
  if constexpr (Series) {
    const double e = N.ax[iq] * g[kDtx * B] + N.ay[iq] * g[kDty * B] + N.az[iq] * g[kDtz * B] +
                     g[kDt2 * B] * N.ir2[iq];
    double s = sqrt_series(e);
    if constexpr (Bistatic) {
      const double eb = N.ax[iq] * g[kDrx * B] + N.ay[iq] * g[kDry * B] +
                        N.az[iq] * g[kDrz * B] + g[kDr2 * B] * N.ir2[iq];
      s = 0.5 * (s + sqrt_series(eb));
    }
    return N.qq[iq] + N.rr[iq] * s + g[kCentreOffset * B];
  }
  double d = one_way(N.xs[iq], N.ys[iq], g[kTx * B], g[kTy * B], g[kT2 * B], g[kTn * B]);
  if constexpr (Bistatic) d = 0.5 * (d + one_way(N.xs[iq], N.ys[iq], g[kRx * B], g[kRy * B], g[kR2 * B], g[kRn * B]));
  return d + g[kOffset * B];
}

// f(std::integral_constant<bool, series>{}, std::integral_constant<bool, bistatic>{}): exact_dr's
// four forms.
template <typename F>
SARCLI_INLINE void by_form(bool series, bool bistatic, F&& f) {
  using T = std::true_type;
  using N = std::false_type;
  if (series) {
    if (bistatic) f(T{}, T{});
    else f(T{}, N{});
  } else {
    if (bistatic) f(N{}, T{});
    else f(N{}, N{});
  }
}

SARCLI_INLINE double exact_dr(const Stage0& A, const double* g, bool series, const NodeGeo& N, std::size_t iq) {
  double d = 0.0;
  by_form(series, A.bistatic, [&](auto se, auto bi) SARCLI_LAMBDA_INLINE {
    d = exact_dr_of<decltype(se)::value, decltype(bi)::value>(g, A.B, N, iq);
  });
  return d;
}

SARCLI_INLINE NodeGeo row_geo(const Scratch0& W) {
  return {W.xs.data(), W.ys.data(), W.ax.data(), W.ay.data(), W.az.data(), W.ir2.data(), W.rr.data(), W.qq.data()};
}

SARCLI_INLINE NodeGeo fit_geo(const Scratch0& W) {
  return {W.fxs.data(), W.fys.data(), W.fax.data(), W.fay.data(), W.faz.data(), W.fir2.data(), W.frr.data(),
          W.fqq.data()};
}

// Profile index, fraction and masked carrier of nodes k0 .. k0+n-1 from their positions f relative
// to the whole bin jb and their phases ph (float32; f within a tile's reach of jb). Position(j)
// and Phase(j) give them for the node's offset j.
template <typename Position, typename Phase>
SARCLI_INLINE void emit0(float n_len, float jb, i32 ioff, std::size_t k0, std::size_t n, Position pos, Phase phase,
                         i32* __restrict idx, float* __restrict frac, float* __restrict cr, float* __restrict ci) {
  const float lo = -jb, hi = n_len - jb, top = hi - 1.0f;
#pragma omp simd
  for (i32 j = 0; j < static_cast<i32>(n); ++j) {   // int32 j: a vector conversion to float on AVX2 too
    const float f = pos(j);
    const bool in = (f >= lo) & (f < hi);   // false for NaN (a node that is no ground point)
    const float fc = std::min(std::max(lo, f), top);   // std::max(lo, NaN) is lo: a node that is no ground point
    const i32 it = static_cast<i32>(fc);   // floor by truncation (a vector conversion everywhere)
    const i32 fi = it - static_cast<i32>(static_cast<float>(it) > fc);
    idx[k0 + j] = ioff + fi;
    frac[k0 + j] = fc - static_cast<float>(fi);
    float c, sn;
    carrier::sincos_f32(phase(j), c, sn);
    cr[k0 + j] = in ? c : 0.0f;   // a select, not a mask times the carrier: a NaN carrier stays out
    ci[k0 + j] = in ? sn : 0.0f;
  }
}

// acc[k] += (cr + i ci)[k] Σ_b w_b[k] src[idx[k] + b] for the block of kBlock0 nodes at k0. Where
// the block's stencil starts idx[k] − k take at most two neighbouring values (node spacing within a
// bin of the profiles'), each node reads seven contiguous samples from the block's common start
// with its six weights shifted by 0 or 1 (blends instead of gathers); otherwise gathers.
template <int Mode>
SARCLI_INLINE void tap6_block(const float* sre, const float* sim, std::size_t len, const i32* idx, const float* frac,
                              const float* __restrict tab, const float* __restrict w, std::size_t ws,
                              const float* __restrict cr, const float* __restrict ci, float* __restrict acc_re,
                              float* __restrict acc_im, std::size_t k0) {
  // which offsets d = (idx[k] − k) − idx[k0] from the first node's start occur: bit d + 1 for d in
  // [−1, 1], bit 3 for any other (one OR over the block's single vector, where a minimum and a
  // maximum take two horizontal reductions); the starts span at most two neighbouring values when
  // no other offset and not both −1 and 1 occur, and the lower is smin
  const i32 s0 = idx[k0];
  u32 seen = 0;
#pragma omp simd reduction(| : seen)
  for (std::size_t i = 0; i < kBlock0; ++i) {
    const u32 d1 = static_cast<u32>(idx[k0 + i] - static_cast<i32>(i) - s0 + 1);   // d + 1; others >= 3 as unsigned
    seen |= u32(1) << std::min(d1, u32(3));
  }
  const i32 smin = s0 - static_cast<i32>(seen & 1u);
  if ((seen & 8u) == 0 && (seen & 5u) != 5u && smin >= 0 && static_cast<std::size_t>(smin) + kBlock0 + 6 <= len) {
    const float *r = sre + smin, *m = sim + smin;
#pragma omp simd
    for (std::size_t i = 0; i < kBlock0; ++i) {
      const std::size_t k = k0 + i;
      float v0, v1, v2, v3, v4, v5;
      weights6<Mode>(frac, tab, w, ws, k, v0, v1, v2, v3, v4, v5);
      const bool sh = idx[k] - static_cast<i32>(i) != smin;
      const float u0 = sh ? 0.0f : v0, u1 = sh ? v0 : v1, u2 = sh ? v1 : v2, u3 = sh ? v2 : v3;
      const float u4 = sh ? v3 : v4, u5 = sh ? v4 : v5, u6 = sh ? v5 : 0.0f;
      const float vr = u0 * r[i] + u1 * r[i + 1] + u2 * r[i + 2] + u3 * r[i + 3] + u4 * r[i + 4] + u5 * r[i + 5] +
                       u6 * r[i + 6];
      const float vi = u0 * m[i] + u1 * m[i + 1] + u2 * m[i + 2] + u3 * m[i + 3] + u4 * m[i + 4] + u5 * m[i + 5] +
                       u6 * m[i + 6];
      acc_re[k] += vr * cr[k] - vi * ci[k];
      acc_im[k] += vr * ci[k] + vi * cr[k];
    }
    return;
  }
  tap6_gather<Mode>(sre, sim, idx + k0, frac + k0, tab, w + k0, ws, cr + k0, ci + k0, acc_re + k0, acc_im + k0,
                    kBlock0);
}

// Row it of sub-image s forms only its nodes start .. start + nq (A.rows: [S, nt, 2], stage 0's
// and the merges' alike); the rest of the row's output is set to zero, and ore, oim point at its
// first formed node. Returns nq.
template <typename RowArgs>
SARCLI_INLINE std::size_t formed_nodes(const RowArgs& A, std::size_t s, std::size_t it, std::size_t& start,
                                       float*& ore, float*& oim) {
  const i64* rb = A.rows + 2 * (s * A.nt + it);
  start = static_cast<std::size_t>(rb[0]);
  const std::size_t nq = static_cast<std::size_t>(rb[1] - rb[0]);
  ore = A.out_re + (s * A.nt + it) * A.nq;
  oim = A.out_im + (s * A.nt + it) * A.nq;
  std::fill(ore, ore + start, 0.0f);
  std::fill(oim, oim + start, 0.0f);
  std::fill(ore + start + nq, ore + A.nq, 0.0f);
  std::fill(oim + start + nq, oim + A.nq, 0.0f);
  ore += start;
  oim += start;
  return nq;
}

// One row (angle it) of sub-aperture s's polar grid. Along the row, each pulse's range and phase
// are smooth in the node: they are evaluated exactly (float64) at three nodes of every tile of
// about kTile0 nodes and by the quadratic through them (float32, relative to the tile's middle
// node) at the others. The quadratic is checked at two more nodes of each tile for the
// sub-aperture's first, middle and last pulses; a tile it misses by more than kFitPhase or kFitBin
// there is evaluated exactly at every node. The phase is demodulated as it is formed
// (ψ = k_c Δr − k_ref q), so the sums are the stored sub-image.
// Only the row's nodes start .. stop-1 (A.rows) are formed, the others set to zero: no later
// stencil reads them.
SARCLI_CLONES
void stage0_row(const Stage0& A, std::size_t s, std::size_t it, Scratch0& W) {
  std::size_t start;
  float *ore, *oim;
  const std::size_t nq = formed_nodes(A, s, it, start, ore, oim);
  if (nq == 0) return;
  const std::size_t n = (nq + kBlock0 - 1) / kBlock0 * kBlock0;
  Frame F = frame_at(A.frame, A.S, s);
  F.q0 += static_cast<double>(start) * A.dq;
  const double tau = F.u0 + static_cast<double>(it) * F.du;
  const int ntap = kTaps[A.kind];
  const bool series = A.series[s];
  i32* idx = W.idx.data();
  float *frac = W.frac.data(), *cr = W.cr.data(), *ci = W.ci.data(), *w = W.w.data();
  float *acc_re = W.acc_re.data(), *acc_im = W.acc_im.data();
  {   // the node, its range from the centre, the series' factors (vectorised: every pointer and
      // setting in a local)
    double *__restrict xs = W.xs.data(), *__restrict ys = W.ys.data(), *__restrict ax = W.ax.data();
    double *__restrict ay = W.ay.data(), *__restrict az = W.az.data(), *__restrict ir2 = W.ir2.data();
    double *__restrict rr = W.rr.data(), *__restrict qq = W.qq.data();
    const double dq = A.dq;
#pragma omp simd
    for (std::size_t iq = 0; iq < nq; ++iq) {
      const double q = F.q0 + static_cast<double>(iq) * dq;
      double x, y;
      node(q, tau, F, x, y);
      const double r = F.cn + q, i2 = 1.0 / (r * r);
      xs[iq] = x; ys[iq] = y;
      ax[iq] = 2.0 * (F.cx - x) * i2;
      ay[iq] = 2.0 * (F.cy - y) * i2;
      az[iq] = 2.0 * F.cz * i2;
      ir2[iq] = i2; rr[iq] = r; qq[iq] = q;
    }
  }
  for (std::size_t k = 0; k < n; ++k) { acc_re[k] = 0.0f; acc_im[k] = 0.0f; }
  const NodeGeo G = row_geo(W), FG = fit_geo(W);
  const std::size_t ntile = std::max<std::size_t>(1, (nq + kTile0 / 2) / kTile0);
  const i64 p0 = A.first[s], p1 = A.first[s] + A.count[s];
  for (std::size_t t = 0; t < ntile; ++t) {   // each tile's fit and check nodes, gathered
    const std::size_t k0 = t * nq / ntile, m = (t + 1) * nq / ntile - k0;
    W.inv[t] = tile_inv(m);
    const std::size_t jm = (m - 1) / 2;
    const std::size_t js[3] = {k0, k0 + jm, k0 + m - 1}, jc[2] = {jm / 2, (jm + m - 1) / 2};
    for (std::size_t i = 0; i < 3; ++i) {   // the tile's fit nodes: its first, middle and last
      const std::size_t k = js[i], f = 3 * t + i;
      W.fxs[f] = W.xs[k]; W.fys[f] = W.ys[k]; W.fax[f] = W.ax[k]; W.fay[f] = W.ay[k]; W.faz[f] = W.az[k];
      W.fir2[f] = W.ir2[k]; W.frr[f] = W.rr[k]; W.fqq[f] = W.qq[k];
    }
    for (std::size_t i = 0; i < 2; ++i) {   // its check nodes: between them
      const std::size_t k = k0 + jc[i], f = 2 * t + i;
      W.cxs[f] = W.xs[k]; W.cys[f] = W.ys[k]; W.cax[f] = W.ax[k]; W.cay[f] = W.ay[k]; W.caz[f] = W.az[k];
      W.cir2[f] = W.ir2[k]; W.crr[f] = W.rr[k]; W.cqq[f] = W.qq[k];
      W.cj[f] = static_cast<double>(jc[i]);
    }
    W.exact[t] = m < 3;
  }
  const double half_len = A.half_len, kref = A.kref;
  // every tile's quadratics for pulse g (W.fit): the exact ranges at all fit nodes, then the fits,
  // each vectorised (the pulse's row and the settings in locals: the stores cannot change them)
  auto fit_all = [&](const double* g) SARCLI_LAMBDA_INLINE {
    const double ib = g[kInvBin * A.B], kc = g[kKc * A.B];
    double gl[kPulseRows];
    for (int r = 0; r < kPulseRows; ++r) gl[r] = g[r * A.B];
    double* __restrict fd = W.fd.data();
    TileFit* __restrict fit = W.fit.data();
    const double* __restrict fqq = W.fqq.data();
    const std::size_t nf = 3 * ntile;
    by_form(series, A.bistatic, [&](auto se, auto bi) SARCLI_LAMBDA_INLINE {
#pragma omp simd
      for (std::size_t f = 0; f < nf; ++f) fd[f] = exact_dr_of<decltype(se)::value, decltype(bi)::value>(gl, 1, FG, f);
    });
#pragma omp simd
    for (std::size_t t = 0; t < ntile; ++t) {
      double pv[3], sv[3];
      for (std::size_t i = 0; i < 3; ++i) {
        pv[i] = fd[3 * t + i] * ib + half_len;
        sv[i] = kc * fd[3 * t + i] - kref * fqq[3 * t + i];
      }
      const std::size_t m = (t + 1) * nq / ntile - t * nq / ntile;
      fit[t] = fit_from(pv, sv, static_cast<double>((m - 1) / 2), W.inv[t]);
    }
  };
  // which tiles the quadratic serves: checked at the check nodes for the first, middle and last
  // pulses, all tiles at once (vectorised)
  const NodeGeo CG{W.cxs.data(), W.cys.data(), W.cax.data(), W.cay.data(), W.caz.data(), W.cir2.data(),
                   W.crr.data(), W.cqq.data()};
  for (i64 p : {p0, p0 + (p1 - p0 - 1) / 2, p1 - 1}) {
    if (p1 <= p0) break;
    const double* g = A.pul + p;
    fit_all(g);
    const double ib = g[kInvBin * A.B], kc = g[kKc * A.B];
    double gl[kPulseRows];
    for (int r = 0; r < kPulseRows; ++r) gl[r] = g[r * A.B];
    double* __restrict cd = W.cd.data();
    const std::size_t nc = 2 * ntile;
    by_form(series, A.bistatic, [&](auto se, auto bi) SARCLI_LAMBDA_INLINE {
#pragma omp simd
      for (std::size_t f = 0; f < nc; ++f) cd[f] = exact_dr_of<decltype(se)::value, decltype(bi)::value>(gl, 1, CG, f);
    });
    const TileFit* __restrict fit = W.fit.data();
    const double *__restrict cqq = W.cqq.data(), *__restrict cj = W.cj.data();
    unsigned char* __restrict bad = W.exact.data();
#pragma omp simd
    for (std::size_t t = 0; t < ntile; ++t) {
      const TileFit f = fit[t];
      bool ok = true;
      for (std::size_t i = 0; i < 2; ++i) {
        const double d = cd[2 * t + i], j = cj[2 * t + i];
        const double pe = d * ib + half_len - f.jb, se = kc * d - kref * cqq[2 * t + i];
        const double ds = se - f.psi(j);
        ok = ok & (std::abs(pe - f.pos(j)) <= kFitBin) &
             (std::abs(ds - 6.283185307179586 * std::nearbyint(ds / 6.283185307179586)) <= kFitPhase);
      }
      bad[t] = bad[t] | static_cast<unsigned char>(!ok);
    }
  }
  const i32 off = static_cast<i32>(A.off);
  const float n_len = static_cast<float>(A.n_len);
  for (i64 p = p0; p < p1; ++p) {
    const float* rp = A.pre + p * A.plen;
    const float* ip = A.pim + p * A.plen;
    const double* g = A.pul + p;   // row r at g[r * B]
    fit_all(g);
    for (std::size_t t = 0; t < ntile; ++t) {
      const std::size_t k0 = t * nq / ntile, m = (t + 1) * nq / ntile - k0;
      if (W.exact[t]) {   // every node exactly (float64), relative to the first node's bin
        const double ib = g[kInvBin * A.B], kc = g[kKc * A.B];
        double jb = 0.0;   // the first node's bin; a NaN range (a node that is no ground point) is skipped
        for (std::size_t j = 0; j < m; ++j) {
          const double b = std::floor(exact_dr(A, g, series, G, k0 + j) * ib + A.half_len);
          if (b == b) {
            jb = b;
            break;
          }
        }
        for (std::size_t j = 0; j < m; ++j) {
          const std::size_t k = k0 + j;
          const double d = exact_dr(A, g, series, G, k);
          const double ph = kc * d - A.kref * W.qq[k];
          W.xpos[k] = d * ib + A.half_len - jb;
          W.xpsi[k] = ph - 6.283185307179586 * std::nearbyint(ph / 6.283185307179586);
        }
        const double *pr = W.xpos.data(), *ps = W.xpsi.data();
        emit0(n_len, static_cast<float>(jb), off + static_cast<i32>(jb), k0, m,
              [&](i32 j) SARCLI_LAMBDA_INLINE { return static_cast<float>(pr[k0 + j]); },
              [&](i32 j) SARCLI_LAMBDA_INLINE { return static_cast<float>(ps[k0 + j]); }, idx, frac, cr, ci);
        continue;
      }
      const TileFit& f = W.fit[t];
      const float p0f = static_cast<float>(f.p0), p1f = static_cast<float>(f.p1), p2f = static_cast<float>(f.p2);
      const float s0f = static_cast<float>(f.s0), s1f = static_cast<float>(f.s1), s2f = static_cast<float>(f.s2);
      const float jmf = static_cast<float>(f.jm);
      // whole blocks of kBlock0 nodes, so that emit0's vector loop has no scalar remainder (a tile
      // of 31 nodes would take 15 of them one at a time): the nodes past the tile are the next
      // tile's, which it writes after, or the row's spare nodes, reset below
      emit0(n_len, static_cast<float>(f.jb), off + static_cast<i32>(f.jb), k0, (m + kBlock0 - 1) / kBlock0 * kBlock0,
            [=](i32 j) SARCLI_LAMBDA_INLINE {
              const float jf = static_cast<float>(j);
              return p0f + (jf - jmf) * (p1f + jf * p2f);
            },
            [=](i32 j) SARCLI_LAMBDA_INLINE {
              const float jf = static_cast<float>(j);
              return s0f + (jf - jmf) * (s1f + jf * s2f);
            },
            idx, frac, cr, ci);
    }
    for (std::size_t k = nq; k < n; ++k) {   // the last block's spare nodes: no contribution
      idx[k] = idx[nq - 1];
      frac[k] = 0.0f;
      cr[k] = 0.0f;
      ci[k] = 0.0f;
    }
    if (ntap == 6) {
      if (A.wmode == kWeightsRead) row_weights<float>(A.kind, frac, n, w, n, A.tab);
      if (A.weights_first && A.wmode != kWeightsRead) {   // the weights in one pass, then the blocks read them
        if (A.wmode == kWeightsSymmetric) weights6_pass<kWeightsSymmetric>(frac, A.tab, n, w, n);
        else weights6_pass<kWeightsPoly>(frac, A.tab, n, w, n);
        for (std::size_t k0 = 0; k0 < n; k0 += kBlock0)
          tap6_block<kWeightsRead>(rp, ip, A.plen, idx, frac, A.tab, w, n, cr, ci, acc_re, acc_im, k0);
        continue;
      }
      by_mode(A.wmode, [&](auto mode) SARCLI_LAMBDA_INLINE {
        for (std::size_t k0 = 0; k0 < n; k0 += kBlock0)
          tap6_block<decltype(mode)::value>(rp, ip, A.plen, idx, frac, A.tab, w, n, cr, ci, acc_re, acc_im, k0);
      });
      continue;
    }
    row_weights<float>(A.kind, frac, nq, w, nq, A.tab);
    for (std::size_t iq = 0; iq < nq; ++iq) {   // 2 or 4 taps
      double vr = 0.0, vi = 0.0;
      for (int b = 0; b < ntap; ++b) {
        vr += static_cast<double>(w[b * nq + iq] * rp[idx[iq] + b]);
        vi += static_cast<double>(w[b * nq + iq] * ip[idx[iq] + b]);
      }
      acc_re[iq] = static_cast<float>(acc_re[iq] + (vr * cr[iq] - vi * ci[iq]));
      acc_im[iq] = static_cast<float>(acc_im[iq] + (vr * ci[iq] + vi * cr[iq]));
    }
  }
  for (std::size_t iq = 0; iq < nq; ++iq) {
    ore[iq] = acc_re[iq];
    oim[iq] = acc_im[iq];
  }
}

// Whether stage 0 forms a row's 6-tap weights in a pass of their own before its blocks read them,
// or inside each block of kBlock0 nodes (the same operations, so the same image bit for bit). On
// the AVX2 and baseline copies a block's loop broadcasts the polynomials' coefficients again for
// every block (to the stack: sixteen vector registers do not hold them), which the pass does once
// a row; the AVX-512 copy takes a block in one vector with the coefficients in its 32 registers,
// and the pass's stores and loads cost it more than they save.
inline bool stage0_weights_first() {
#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__) && !defined(SARCLI_NO_CLONES)
  return !__builtin_cpu_supports("x86-64-v4");   // the copy the clones' resolver picks
#elif defined(__AVX512F__)
  return false;
#else
  return true;
#endif
}

}  // namespace

void stage0(in<float, 2> pre, in<float, 2> pim, in<i64, 1> first, in<i64, 1> count, in<double, 2> pulses,
            in<bool, 1> series, in<double, 2> frame, in<i64, 3> rows, in<float, 2> tab, const Stage0Options& o,
            out<float, 3> out_re, out<float, 3> out_im) {
  const int kind = o.kind;
  const std::size_t S = out_re.shape(0), nt = out_re.shape(1), nq = out_re.shape(2), B = pre.shape(0);
  if (kind < interp::kLinear || kind >= interp::kKinds) throw nb::value_error("stage0: unknown interpolation kind");
  if (pim.shape(0) != B || pim.shape(1) != pre.shape(1) || pulses.shape(0) != kPulseRows || pulses.shape(1) != B ||
      first.shape(0) != S || count.shape(0) != S || series.shape(0) != S || frame.shape(0) != kFrameRows ||
      frame.shape(1) != S || tab.shape(0) != 6 || tab.shape(1) != 8 || out_im.shape(0) != S ||
      out_im.shape(1) != nt || out_im.shape(2) != nq || rows.shape(0) != S || rows.shape(1) != nt ||
      rows.shape(2) != 2)
    throw nb::value_error("stage0: inconsistent shapes");
  check_rows(rows.data(), S * nt, nq, "stage0");
  for (std::size_t s = 0; s < S; ++s)
    if (first.data()[s] < 0 || count.data()[s] < 0 || static_cast<std::size_t>(first.data()[s] + count.data()[s]) > B)
      throw nb::value_error("stage0: sub-aperture pulses out of range");
  const int ntap = kTaps[kind];
  const Stage0 A{pre.data(), pim.data(), pre.shape(1), first.data(), count.data(), pulses.data(), B,
                 series.data(), frame.data(), S, nt, nq, tab.data(), kind, weight_mode(kind, tab.data()),
                 o.weights_first < 0 ? stage0_weights_first() : o.weights_first != 0, o.bistatic,
                 o.half_len, o.n_len, static_cast<double>(o.pad - (ntap / 2 - 1)), o.dq, o.kref, out_re.data(),
                 out_im.data(), rows.data()};
  nb::gil_scoped_release nogil;
  const long jobs = static_cast<long>(S * nt);
#pragma omp parallel
  {
    Scratch0 W(nq);
// rows in turn to whichever thread is free: each row is written by one thread alone, so the image
// does not depend on the schedule, and a thread the system holds back leaves its rows to the others
#pragma omp for schedule(dynamic)
    for (long job = 0; job < jobs; ++job) stage0_row(A, job / nt, job % nt, W);
  }
}

namespace {

// ---- merges and the final stage ----------------------------------------------------------------

struct Child {
  const float *re, *im;   // [nt, nq] planes of one sub-image
  std::size_t nt, nq;
  Frame f;
};

// Work arrays of one row of n points (children of up to ncmax - 6 range samples).
struct RowScratch {
  std::vector<double> xs, ys, qp, qs, ts, slope, ftc;
  std::vector<i32> idx_q, idx_t, idx_c, seg, brk;
  std::vector<float> cr, ci, acc_re, acc_im, fq, ft, wq, wt, wtc, okc, gre, gim, ftc32;
  RowScratch(std::size_t n, std::size_t ncmax)
      : xs(n), ys(n), qp(n), qs(n), ts(n), slope(n), ftc(ncmax), idx_q(n), idx_t(n), idx_c(ncmax), seg(ncmax), brk(n), cr(n), ci(n),
        acc_re(n), acc_im(n), fq(n), ft(n), wq(6 * n), wt(6 * n), wtc(6 * ncmax), okc(ncmax), gre(ncmax),
        gim(ncmax), ftc32(ncmax) {}
};

// eight float32 lanes (GCC/Clang vector extension: one AVX register, two SSE registers); the
// helpers that pass them are always inlined, so no call crosses the baseline ABI
#pragma GCC diagnostic ignored "-Wpsabi"
typedef float v8f __attribute__((vector_size(32)));

SARCLI_INLINE v8f load8(const float* p) {
  v8f v;
  __builtin_memcpy(&v, p, sizeof v);
  return v;
}

// The 6-tap weights of fraction t as lanes 0-5 of a vector (lanes 6, 7 zero): the degree-7
// polynomials with coefficient vectors ck[k] (lane b: tab[b][k]).
SARCLI_INLINE v8f weights8(const v8f* ck, float t) {
  const float x = 2.0f * t - 1.0f;
  v8f w = ck[7];
  for (int k = 6; k >= 0; --k) w = w * x + ck[k];
  return w;
}

typedef int v8i __attribute__((vector_size(32)));

SARCLI_INLINE void store8(float* p, v8f v) { __builtin_memcpy(p, &v, sizeof v); }

// The lane sums of eight vectors a[k] as the lanes k of one vector: pairs, then quadruples, then
// halves added across the vectors (14 shuffles and 7 additions for eight sums).
SARCLI_INLINE v8f lane_sums8(const v8f* a) {
  const v8i ev{0, 8, 2, 10, 4, 12, 6, 14}, od{1, 9, 3, 11, 5, 13, 7, 15};
  const v8f b0 = __builtin_shuffle(a[0], a[1], ev) + __builtin_shuffle(a[0], a[1], od);
  const v8f b1 = __builtin_shuffle(a[2], a[3], ev) + __builtin_shuffle(a[2], a[3], od);
  const v8f b2 = __builtin_shuffle(a[4], a[5], ev) + __builtin_shuffle(a[4], a[5], od);
  const v8f b3 = __builtin_shuffle(a[6], a[7], ev) + __builtin_shuffle(a[6], a[7], od);
  // b0 = (a0 01, a1 01, a0 23, a1 23, a0 45, a1 45, a0 67, a1 67), b1 the same of a2, a3, ...
  const v8i lo{0, 1, 8, 9, 4, 5, 12, 13}, hi{2, 3, 10, 11, 6, 7, 14, 15};
  const v8f c0 = __builtin_shuffle(b0, b1, lo) + __builtin_shuffle(b0, b1, hi);
  const v8f c1 = __builtin_shuffle(b2, b3, lo) + __builtin_shuffle(b2, b3, hi);
  // c0 = (a0 0-3, a1 0-3, a2 0-3, a3 0-3, a0 4-7, a1 4-7, a2 4-7, a3 4-7), c1 the same of a4 .. a7
  return __builtin_shuffle(c0, c1, v8i{0, 1, 2, 3, 8, 9, 10, 11}) +
         __builtin_shuffle(c0, c1, v8i{4, 5, 6, 7, 12, 13, 14, 15});
}

// Add one sub-image, interpolated at the polar coordinates (qs, ts) of n points and re-modulated
// by e^{i k_ref (q − qref)}, to acc: positions and carriers, weights, then the 2-D stencil. With
// the 6-tap polynomial kernel, each of a point's six stencil rows is read as one 8-lane vector
// (lanes 6, 7 weighted zero), the range weights are one vector polynomial, and the lane sums of
// eight points are taken together (lane_sums8).
SARCLI_INLINE void polar_row(const Child& C, double dq, double kref, const double* qs, const double* ts,
                             const double* qref, int kind, const float* tab_q, const float* tab_t, std::size_t n,
                             RowScratch& W) {
  const int ntap = kTaps[kind];
  const double lo = -(ntap / 2 - 1), nt = static_cast<double>(C.nt), nq = static_cast<double>(C.nq);
  const double inv_dq = 1.0 / dq, inv_dt = 1.0 / C.f.du, hk = 0.5 * kref;
  i32 *idx_q = W.idx_q.data(), *idx_t = W.idx_t.data();
  float *fq = W.fq.data(), *ft = W.ft.data(), *wq = W.wq.data(), *wt = W.wt.data();
  float *cr = W.cr.data(), *ci = W.ci.data(), *acc_re = W.acc_re.data(), *acc_im = W.acc_im.data();
  const double q0 = C.f.q0, u0 = C.f.u0;
  for (std::size_t i = 0; i < n; ++i) {   // angular positions; cr holds whether they are inside
    double tt;
    bool okt;
    idx_t[i] = locate((ts[i] - u0) * inv_dt, lo, nt, ntap, tt, okt);
    ft[i] = static_cast<float>(tt);
    cr[i] = okt ? 1.0f : 0.0f;
  }
  for (std::size_t i = 0; i < n; ++i) {   // range positions and carriers
    double tq;
    bool okq;
    idx_q[i] = locate((qs[i] - q0) * inv_dq, lo, nq, ntap, tq, okq);
    fq[i] = static_cast<float>(tq);
    float c, s;
    carrier::sincos_half_f32(hk * (qs[i] - qref[i]), c, s);
    const bool m = okq && cr[i] != 0.0f;
    cr[i] = m ? c : 0.0f;   // not a mask times the carrier: a NaN one (no ground point) stays out
    ci[i] = m ? s : 0.0f;
  }
  row_weights<float>(kind, ft, n, wt, n, tab_t);
  const std::size_t cq = C.nq, plane = C.nt * C.nq;
  if (kind == interp::kPoly6) {
    v8f ck[8] = {};
    for (int k = 0; k < 8; ++k)
      for (int b = 0; b < 8; ++b) ck[k][b] = b < 6 ? tab_q[8 * b + k] : 0.0f;
    // a point's stencil rows weighted in angle and, lane by lane, in range (lanes 6, 7 weighted zero)
    auto stencil = [&](std::size_t i, v8f& pr, v8f& pi) SARCLI_LAMBDA_INLINE {
      const std::size_t base = static_cast<std::size_t>(idx_t[i]) * cq + static_cast<std::size_t>(idx_q[i]);
      const v8f w8 = weights8(ck, fq[i]);
      v8f sr = {}, si = {};
      if (base + 5 * cq + 8 <= plane) {
        for (int a = 0; a < 6; ++a) {
          const float ta = wt[a * n + i];
          sr += ta * load8(C.re + base + a * cq);
          si += ta * load8(C.im + base + a * cq);
        }
      } else {   // the stencil ends the plane: read six lanes
        for (int a = 0; a < 6; ++a) {
          const float ta = wt[a * n + i];
          for (int b = 0; b < 6; ++b) {
            sr[b] += ta * C.re[base + a * cq + b];
            si[b] += ta * C.im[base + a * cq + b];
          }
        }
      }
      pr = sr * w8;
      pi = si * w8;
    };
    // eight points at a time: their lane sums by one transposing reduction, whose sum of a vector
    // does not depend on the others (a short last group, zeros beside it, sums its points alike:
    // the image does not depend on how the points are cut into rows or bands)
    auto add8 = [](float* ar, float* ai, const float* c, const float* sn, v8f vr, v8f vi) SARCLI_LAMBDA_INLINE {
      const v8f c8 = load8(c), s8 = load8(sn);
      store8(ar, load8(ar) + (vr * c8 - vi * s8));
      store8(ai, load8(ai) + (vr * s8 + vi * c8));
    };
    std::size_t i = 0;
    for (; i + 8 <= n; i += 8) {
      v8f pr[8], pi[8];
      for (int k = 0; k < 8; ++k) stencil(i + k, pr[k], pi[k]);
      add8(acc_re + i, acc_im + i, cr + i, ci + i, lane_sums8(pr), lane_sums8(pi));
    }
    if (i < n) {
      const std::size_t m = n - i;
      v8f pr[8] = {}, pi[8] = {};
      for (std::size_t k = 0; k < m; ++k) stencil(i + k, pr[k], pi[k]);
      float c[8] = {}, sn[8] = {}, ar[8] = {}, ai[8] = {};
      std::copy(cr + i, cr + n, c);
      std::copy(ci + i, ci + n, sn);
      std::copy(acc_re + i, acc_re + n, ar);
      std::copy(acc_im + i, acc_im + n, ai);
      add8(ar, ai, c, sn, lane_sums8(pr), lane_sums8(pi));
      std::copy(ar, ar + m, acc_re + i);
      std::copy(ai, ai + m, acc_im + i);
    }
    return;
  }
  row_weights<float>(kind, fq, n, wq, n, tab_q);
  for (std::size_t i = 0; i < n; ++i) {
    float vr = 0.0f, vi = 0.0f;
    for (int a = 0; a < ntap; ++a) {
      const float* r = C.re + (idx_t[i] + a) * cq + idx_q[i];
      const float* m = C.im + (idx_t[i] + a) * cq + idx_q[i];
      float rr = 0.0f, ri = 0.0f;
      for (int b = 0; b < ntap; ++b) {
        rr += wq[b * n + i] * r[b];
        ri += wq[b * n + i] * m[b];
      }
      vr += wt[a * n + i] * rr;
      vi += wt[a * n + i] * ri;
    }
    acc_re[i] += vr * cr[i] - vi * ci[i];
    acc_im[i] += vr * ci[i] + vi * cr[i];
  }
}

// g[jj] = okc[jj] Σ_a w_a[jj] F[st + a][jlo + jj] for the columns jj in [j0, j1) that share the
// stencil rows st .. st+5 (contiguous loads); weights formed in the same pass (weights6).
template <int Mode>
SARCLI_INLINE void col_run(const float* re, const float* im, std::size_t cq, std::size_t st, std::size_t jlo,
                           const float* frac, const float* tab, const float* w, std::size_t ws, const float* okc,
                           float* gre, float* gim, std::size_t j0, std::size_t j1) {
  const float* r0 = re + st * cq + jlo;
  const float* m0 = im + st * cq + jlo;
  const float *r1 = r0 + cq, *r2 = r0 + 2 * cq, *r3 = r0 + 3 * cq, *r4 = r0 + 4 * cq, *r5 = r0 + 5 * cq;
  const float *m1 = m0 + cq, *m2 = m0 + 2 * cq, *m3 = m0 + 3 * cq, *m4 = m0 + 4 * cq, *m5 = m0 + 5 * cq;
#pragma omp simd
  for (std::size_t jj = j0; jj < j1; ++jj) {
    float v0, v1, v2, v3, v4, v5;
    weights6<Mode>(frac, tab, w, ws, jj, v0, v1, v2, v3, v4, v5);
    const float m = okc[jj];
    gre[jj] = m * (v0 * r0[jj] + v1 * r1[jj] + v2 * r2[jj] + v3 * r3[jj] + v4 * r4[jj] + v5 * r5[jj]);
    gim[jj] = m * (v0 * m0[jj] + v1 * m1[jj] + v2 * m2[jj] + v3 * m3[jj] + v4 * m4[jj] + v5 * m5[jj]);
  }
}

// polar_row in two 1-D passes, for n >= 2 points whose child range qs increases strictly (a
// parent's row of constant u seen from a child: the merges). Along the row the child coordinates
// trace a smooth curve u = T(q). Pass 1 interpolates every child column j the row's stencils touch
// in u, at T(q_j) (T linear between the row's points, extrapolated past its ends):
// g_j = F(q_j, T(q_j)). Pass 2 interpolates g in q at each point: 2·ntap taps a point, not ntap².
// Both passes walk runs of points that share a stencil row (pass 1) or a stencil shift (pass 2),
// so their loads are contiguous; float32 like the stored sub-images.
SARCLI_INLINE void separable_row(const Child& C, double dq, double kref, const double* qs, const double* ts,
                                 const double* qref, int kind, const float* tab_q, const float* tab_t, int mode_q,
                                 int mode_t, std::size_t n, RowScratch& W) {
  const int ntap = kTaps[kind];
  const double lo = -(ntap / 2 - 1), nt = static_cast<double>(C.nt), nq = static_cast<double>(C.nq);
  const double inv_dq = 1.0 / dq, inv_dt = 1.0 / C.f.du, hk = 0.5 * kref;
  i32 *idx_q = W.idx_q.data(), *idx_c = W.idx_c.data();
  float *fq = W.fq.data(), *wq = W.wq.data(), *wt = W.wtc.data(), *okc = W.okc.data();
  float *gre = W.gre.data(), *gim = W.gim.data(), *ft32 = W.ftc32.data();
  float *cr = W.cr.data(), *ci = W.ci.data(), *acc_re = W.acc_re.data(), *acc_im = W.acc_im.data();
  double *slope = W.slope.data(), *ft = W.ftc.data();
  for (std::size_t i = 0; i < n; ++i) {   // positions, fractions, carriers
    double tq;
    bool okq;
    idx_q[i] = locate((qs[i] - C.f.q0) * inv_dq, lo, nq, ntap, tq, okq);
    fq[i] = static_cast<float>(tq);
    float c, s;
    carrier::sincos_half_f32(hk * (qs[i] - qref[i]), c, s);
    cr[i] = okq ? c : 0.0f;
    ci[i] = okq ? s : 0.0f;
    okc[i] = okq ? 1.0f : 0.0f;
  }
  // the points whose stencils lie inside form one interval [i0, i1] (qs increases)
  std::size_t i0 = 0;
  while (i0 < n && okc[i0] == 0.0f) ++i0;
  if (i0 == n) return;
  std::size_t i1 = n - 1;
  while (okc[i1] == 0.0f) --i1;
  const i32 jlo = idx_q[i0];
  const std::size_t ncol = static_cast<std::size_t>(idx_q[i1] + ntap - jlo);
  // T at the columns: linear between the row's points (extrapolated past its ends), then located in u
  // (the slopes' quotients in float32: a column lies within a point's spacing of its segment's
  // point, so their rounding moves T by about 1e-7 of that spacing's step in u, and a float32
  // vector division costs a fraction of a float64 one's)
  for (std::size_t i = 0; i + 1 < n; ++i)
    slope[i] = static_cast<float>(ts[i + 1] - ts[i]) / static_cast<float>(qs[i + 1] - qs[i]);
  // segment of each column: the last point k in [1, n − 2] with qs[k] <= q_j (0 if none). With
  // c_k the first column at or past point k, that is the last k with c_k <= j. Columns and points share
  // their spacing in q, so along a run of points whose c_k rises by one a point each column's
  // segment is its own point (k − c_k constant: contiguous loads), and a column between runs keeps
  // the last point before it; the runs are few a row (list_breaks).
  const i32 top = static_cast<i32>(n) - 2, nc = static_cast<i32>(ncol);
  const double qc0 = C.f.q0 + static_cast<double>(jlo) * dq, inv_col = 1.0 / dq;
  i32 *cpt = W.idx_t.data(), *brk = W.brk.data();
  for (std::size_t i = 0; i < n; ++i) cpt[i] = static_cast<i32>(std::ceil((qs[i] - qc0) * inv_col));
  auto fill = [&](i32 j0, i32 j1, i32 shift, bool run) SARCLI_LAMBDA_INLINE {   // k = j + shift, or shift
#pragma omp simd
    for (i32 jj = j0; jj < j1; ++jj) {
      const std::size_t k = static_cast<std::size_t>(run ? jj + shift : shift);
      const double qj = C.f.q0 + static_cast<double>(jlo + jj) * dq;
      ft[jj] = ts[k] + (qj - qs[k]) * slope[k];
    }
  };
  const std::size_t nb = top >= 1 ? list_breaks(cpt, 1, static_cast<std::size_t>(top) + 1, 1, brk) : 0;
  i32 j = 0;   // columns below j are done
  for (std::size_t b = 0; top >= 1 && b <= nb; ++b) {   // runs [a, e) of points
    const i32 a = b == 0 ? 1 : brk[b - 1], e = b < nb ? brk[b] : top + 1;
    const i32 ca = cpt[a], ce = std::min(cpt[e - 1] + 1, nc);
    if (j < std::min(ca, nc)) fill(j, std::min(ca, nc), a - 1, false);   // a gap: the point before the run
    if (std::max(ca, 0) < ce) fill(std::max(ca, 0), ce, a - ca, true);    // later points win a shared column
    j = std::max(j, ce);
  }
  if (j < nc) fill(j, nc, std::max(top, 0), false);
  for (std::size_t jj = 0; jj < ncol; ++jj) {
    double tt;
    bool okt;
    idx_c[jj] = locate((ft[jj] - C.f.u0) * inv_dt, lo, nt, ntap, tt, okt);
    ft32[jj] = static_cast<float>(tt);
    okc[jj] = okt ? 1.0f : 0.0f;
  }
  const std::size_t cq = C.nq;
  if (ntap == 6) {   // runs of columns reading the same six child rows: contiguous loads
    if (mode_t == kWeightsRead) row_weights<float>(kind, ft32, ncol, wt, ncol, tab_t);
    i32* brk = W.seg.data();   // the columns where the stencil row changes
    const std::size_t nb = list_breaks(idx_c, 0, ncol, 0, brk);
    std::size_t j0 = 0;
    for (std::size_t b = 0; b <= nb; ++b) {
      const std::size_t j1 = b < nb ? static_cast<std::size_t>(brk[b]) : ncol;
      const std::size_t st = static_cast<std::size_t>(idx_c[j0]);
      by_mode(mode_t, [&](auto mode) SARCLI_LAMBDA_INLINE {
        col_run<decltype(mode)::value>(C.re, C.im, cq, st, jlo, ft32, tab_t, wt, ncol, okc, gre, gim, j0, j1);
      });
      j0 = j1;
    }
    // pass 2 over the points inside (the others have a zero carrier): runs of points whose
    // stencil starts advance with them
    if (mode_q == kWeightsRead) row_weights<float>(kind, fq, n, wq, n, tab_q);
    for (std::size_t i = i0; i <= i1; ++i) idx_q[i] -= jlo;
    const bool runs = for_runs(idx_q, i0, i1 + 1, n, W.brk.data(), [&](std::size_t k0, std::size_t k1, std::ptrdiff_t off)
                                                            SARCLI_LAMBDA_INLINE {
      by_mode(mode_q, [&](auto mode) SARCLI_LAMBDA_INLINE {
        tap6_run<decltype(mode)::value>(gre, gim, off, fq, tab_q, wq, n, cr, ci, acc_re, acc_im, k0, k1);
      });
    });
    (void)runs;
    return;
  }
  row_weights<float>(kind, ft32, ncol, wt, ncol, tab_t);
  for (std::size_t jj = 0; jj < ncol; ++jj) {
    const std::size_t base = static_cast<std::size_t>(idx_c[jj]) * cq + jlo + jj;
    float vr = 0.0f, vi = 0.0f;
    for (int a = 0; a < ntap; ++a) {
      vr += wt[a * ncol + jj] * C.re[base + a * cq];
      vi += wt[a * ncol + jj] * C.im[base + a * cq];
    }
    gre[jj] = okc[jj] * vr;
    gim[jj] = okc[jj] * vi;
  }
  row_weights<float>(kind, fq, n, wq, n, tab_q);
  for (std::size_t kk = i0; kk <= i1; ++kk) {
    const float* gr = gre + (idx_q[kk] - jlo);
    const float* gi = gim + (idx_q[kk] - jlo);
    float vr = 0.0f, vi = 0.0f;
    for (int b = 0; b < ntap; ++b) {
      vr += wq[b * n + kk] * gr[b];
      vi += wq[b * n + kk] * gi[b];
    }
    acc_re[kk] += vr * cr[kk] - vi * ci[kk];
    acc_im[kk] += vr * ci[kk] + vi * cr[kk];
  }
}

struct Merge {
  const float *cre, *cim;   // children [C, cnt, cnq]
  std::size_t C, cnt, cnq;
  const double *cframe, *pframe;
  std::size_t P, nt, nq;
  const i64 *first, *count;
  int kind;
  const float *tab_q, *tab_t;
  double dq, kref;
  float *out_re, *out_im;
  int mode_q, mode_t;   // WeightMode of the range and angular kernels
  const i64* rows;      // [P, nt, 2]: the nodes start .. stop-1 of each parent row that are formed
};

// A parent's row: only its nodes start .. stop-1 (A.rows) are formed, the others set to zero.
SARCLI_CLONES
void merge_row(const Merge& A, std::size_t s, std::size_t it, RowScratch& W) {
  std::size_t start;
  float *ore, *oim;
  const std::size_t nq = formed_nodes(A, s, it, start, ore, oim);
  if (nq == 0) return;
  Frame pf = frame_at(A.pframe, A.P, s);
  pf.q0 += static_cast<double>(start) * A.dq;
  const double tau = pf.u0 + static_cast<double>(it) * pf.du;
  double *__restrict xs = W.xs.data(), *__restrict ys = W.ys.data(), *__restrict qp = W.qp.data();
  double *qs = W.qs.data(), *ts = W.ts.data();
  float *__restrict acc_re = W.acc_re.data(), *__restrict acc_im = W.acc_im.data();
  const double dq = A.dq;   // in a local: the stores cannot change it, and the loop vectorises
  for (std::size_t iq = 0; iq < nq; ++iq) {
    const double q = pf.q0 + static_cast<double>(iq) * dq;
    double x, y;
    node(q, tau, pf, x, y);
    qp[iq] = q;
    xs[iq] = x;
    ys[iq] = y;
    acc_re[iq] = 0.0f;
    acc_im[iq] = 0.0f;
  }
  for (i64 c = A.first[s]; c < A.first[s] + A.count[s]; ++c) {
    const Child ch{A.cre + c * A.cnt * A.cnq, A.cim + c * A.cnt * A.cnq, A.cnt, A.cnq,
                   frame_at(A.cframe, A.C, static_cast<std::size_t>(c))};
    for (std::size_t iq = 0; iq < nq; ++iq) {
      double q, u;
      coords(xs[iq], ys[iq], ch.f, q, u);
      qs[iq] = q;
      ts[iq] = u;
    }
    std::size_t falls = 0;   // points whose child range does not increase (or is NaN: no ground point)
    for (std::size_t iq = 1; iq < nq; ++iq) falls += !(qs[iq] > qs[iq - 1]);
    falls += nq > 0 && !(qs[0] == qs[0]);
    if (nq >= 2 && falls == 0)
      separable_row(ch, A.dq, A.kref, qs, ts, qp, A.kind, A.tab_q, A.tab_t, A.mode_q, A.mode_t, nq, W);
    else
      polar_row(ch, A.dq, A.kref, qs, ts, qp, A.kind, A.tab_q, A.tab_t, nq, W);
  }
  for (std::size_t iq = 0; iq < nq; ++iq) {
    ore[iq] = acc_re[iq];
    oim[iq] = acc_im[iq];
  }
}

void check_tabs(in<float, 2>& tab_q, in<float, 2>& tab_t, int kind, const char* who) {
  if (kind < interp::kLinear || kind >= interp::kKinds)
    throw nb::value_error((std::string(who) + ": unknown interpolation kind").c_str());
  if (tab_q.shape(0) != 6 || tab_q.shape(1) != 8 || tab_t.shape(0) != 6 || tab_t.shape(1) != 8)
    throw nb::value_error((std::string(who) + ": kernel tables must be [6, 8]").c_str());
}

}  // namespace

void merge(in<float, 3> cre, in<float, 3> cim, in<double, 2> cframe, in<double, 2> pframe, in<i64, 1> first,
           in<i64, 1> count, in<i64, 3> rows, in<float, 2> tab_q, in<float, 2> tab_t, int kind, double dq,
           double kref, out<float, 3> out_re, out<float, 3> out_im) {
  const std::size_t C = cre.shape(0), P = out_re.shape(0), nt = out_re.shape(1), nq = out_re.shape(2);
  check_tabs(tab_q, tab_t, kind, "merge");
  if (cim.shape(0) != C || cim.shape(1) != cre.shape(1) || cim.shape(2) != cre.shape(2) ||
      cframe.shape(0) != kFrameRows || cframe.shape(1) != C || pframe.shape(0) != kFrameRows ||
      pframe.shape(1) != P || first.shape(0) != P || count.shape(0) != P || out_im.shape(0) != P ||
      out_im.shape(1) != nt || out_im.shape(2) != nq || rows.shape(0) != P || rows.shape(1) != nt ||
      rows.shape(2) != 2)
    throw nb::value_error("merge: inconsistent shapes");
  check_rows(rows.data(), P * nt, nq, "merge");
  for (std::size_t s = 0; s < P; ++s)
    if (first.data()[s] < 0 || count.data()[s] < 0 || static_cast<std::size_t>(first.data()[s] + count.data()[s]) > C)
      throw nb::value_error("merge: children out of range");
  if (cre.shape(1) < 6 || cre.shape(2) < 6) throw nb::value_error("merge: child grids need at least 6 x 6 nodes");
  const Merge A{cre.data(), cim.data(), C, cre.shape(1), cre.shape(2), cframe.data(), pframe.data(), P, nt, nq,
                first.data(), count.data(), kind, tab_q.data(), tab_t.data(), dq, kref, out_re.data(),
                out_im.data(), weight_mode(kind, tab_q.data()), weight_mode(kind, tab_t.data()), rows.data()};
  const std::size_t ncmax = std::max(cre.shape(2), nq) + 6;
  nb::gil_scoped_release nogil;
  const long jobs = static_cast<long>(P * nt);
#pragma omp parallel
  {
    RowScratch W(nq, ncmax);
#pragma omp for schedule(dynamic)   // as in stage 0
    for (long job = 0; job < jobs; ++job) merge_row(A, job / nt, job % nt, W);
  }
}

namespace {

struct Final {
  const float *cre, *cim;
  std::size_t C, cnt, cnq;
  const double* cframe;
  const double *x, *y;
  std::size_t nx;
  int kind;
  const float *tab_q, *tab_t;
  double dq, kref;
  double* img;   // complex128 [ny, nx] as interleaved pairs
};

SARCLI_CLONES
void final_row(const Final& A, std::size_t row, RowScratch& W) {
  const std::size_t nx = A.nx;
  const double yv = A.y[row];
  double *qs = W.qs.data(), *ts = W.ts.data(), *zero = W.qp.data(), *sum_re = W.xs.data(), *sum_im = W.ys.data();
  float *acc_re = W.acc_re.data(), *acc_im = W.acc_im.data();
  for (std::size_t ix = 0; ix < nx; ++ix) { sum_re[ix] = 0.0; sum_im[ix] = 0.0; zero[ix] = 0.0; }
  for (std::size_t c = 0; c < A.C; ++c) {
    const Child ch{A.cre + c * A.cnt * A.cnq, A.cim + c * A.cnt * A.cnq, A.cnt, A.cnq, frame_at(A.cframe, A.C, c)};
    for (std::size_t ix = 0; ix < nx; ++ix) {
      coords(A.x[ix], yv, ch.f, qs[ix], ts[ix]);
      acc_re[ix] = 0.0f;
      acc_im[ix] = 0.0f;
    }
    polar_row(ch, A.dq, A.kref, qs, ts, zero, A.kind, A.tab_q, A.tab_t, nx, W);
    // each sub-image's part summed in float64: the image does not depend on how the sub-images
    // are grouped into calls
    for (std::size_t ix = 0; ix < nx; ++ix) { sum_re[ix] += acc_re[ix]; sum_im[ix] += acc_im[ix]; }
  }
  double* o = A.img + 2 * row * nx;
  for (std::size_t ix = 0; ix < nx; ++ix) {
    o[2 * ix] += sum_re[ix];
    o[2 * ix + 1] += sum_im[ix];
  }
}

}  // namespace

void final_stage(in<float, 3> cre, in<float, 3> cim, in<double, 2> cframe, in<double, 1> x, in<double, 1> y,
                 in<float, 2> tab_q, in<float, 2> tab_t, int kind, double dq, double kref,
                 out<std::complex<double>, 2> img) {
  const std::size_t C = cre.shape(0), ny = y.shape(0), nx = x.shape(0);
  check_tabs(tab_q, tab_t, kind, "final_stage");
  if (cim.shape(0) != C || cim.shape(1) != cre.shape(1) || cim.shape(2) != cre.shape(2) ||
      cframe.shape(0) != kFrameRows || cframe.shape(1) != C || img.shape(0) != ny || img.shape(1) != nx)
    throw nb::value_error("final_stage: inconsistent shapes");
  if (cre.shape(1) < 6 || cre.shape(2) < 6) throw nb::value_error("final_stage: grids need at least 6 x 6 nodes");
  const Final A{cre.data(), cim.data(), C, cre.shape(1), cre.shape(2), cframe.data(), x.data(), y.data(), nx,
                kind, tab_q.data(), tab_t.data(), dq, kref, reinterpret_cast<double*>(img.data())};
  nb::gil_scoped_release nogil;
#pragma omp parallel
  {
    RowScratch W(nx, 6);
#pragma omp for schedule(dynamic)   // as in stage 0
    for (long row = 0; row < static_cast<long>(ny); ++row) final_row(A, row, W);
  }
}

namespace {

// ---- deapodization at each pulse's tones -------------------------------------------------------

SARCLI_CLONES
void tone_pulse(const double* k, const double* a, std::size_t L, std::size_t P, std::size_t p, double b,
                double inv_h, const double* inv_psi, std::size_t top, double* o, std::size_t M, double* acc) {
  for (std::size_t j = 0; j < M; ++j) acc[j] = 1.0;
  for (std::size_t l = 0; l < L; ++l) {   // level by level, vectorised over the frequencies
    const double al = a[l * P + p];
#pragma omp simd
    for (std::size_t j = 0; j < M; ++j) {
      const double x = std::abs(k[j] * al + b) * inv_h;
      const std::size_t i = std::min(static_cast<std::size_t>(x), top);
      const double fr = x - static_cast<double>(i);
      acc[j] *= inv_psi[i] + fr * (inv_psi[i + 1] - inv_psi[i]);
    }
  }
  for (std::size_t j = 0; j < M; ++j) o[j] *= acc[j];
}

}  // namespace

void tone_weights(in<double, 2> k, in<double, 2> a, double b, double inv_h, in<double, 1> inv_psi,
                  out<double, 2> w) {
  const std::size_t P = w.shape(0), M = w.shape(1), L = a.shape(0);
  if ((k.shape(0) != 1 && k.shape(0) != P) || k.shape(1) != M || a.shape(1) != P || inv_psi.shape(0) < 2)
    throw nb::value_error("tone_weights: inconsistent shapes");
  const double *kp = k.data(), *ap = a.data(), *psi = inv_psi.data();
  double* o = w.data();
  const bool per_pulse = k.shape(0) > 1;
  const std::size_t top = inv_psi.shape(0) - 2;
  nb::gil_scoped_release nogil;
  // threads where the work (tens of nanoseconds a pulse, frequency and level) is well above a
  // parallel region's few microseconds: stage 0's blocks of 64 pulses qualify
#pragma omp parallel if (P * M * L > (std::size_t(1) << 14))
  {
    std::vector<double> acc(M);
#pragma omp for schedule(static)
    for (long p = 0; p < static_cast<long>(P); ++p)
      tone_pulse(kp + (per_pulse ? p * M : 0), ap, L, P, p, b, inv_h, psi, top, o + p * M, M, acc.data());
  }
}

namespace {

// row_weights and the carrier on the SIMD copy this CPU runs (as the kernels call them).
SARCLI_CLONES
void weights_run(int kind, const float* frac, std::size_t n, float* w, const float* tab) {
  row_weights<float>(kind, frac, n, w, n, tab);
}

SARCLI_CLONES
void weights_run(int kind, const double* frac, std::size_t n, double* w, const double* tab) {
  row_weights<double>(kind, frac, n, w, n, tab);
}

SARCLI_CLONES
void carrier_run(const double* ph, std::size_t n, float* c, float* s) {
  for (std::size_t i = 0; i < n; ++i) carrier::cos_sin_f32(ph[i], c[i], s[i]);
}

}  // namespace

template <typename T>
void weights_of(int kind, in<T, 1> frac, in<T, 2> tab, out<T, 2> w) {
  if (kind < interp::kLinear || kind >= interp::kKinds) throw nb::value_error("row_weights: unknown interpolation kind");
  const std::size_t n = frac.shape(0);
  if (w.shape(0) != static_cast<std::size_t>(kTaps[kind]) || w.shape(1) != n || tab.shape(0) != 6 ||
      tab.shape(1) != 8)
    throw nb::value_error("row_weights: out must be [taps, n] and tab [6, 8]");
  weights_run(kind, frac.data(), n, w.data(), tab.data());
}

// The carrier (cos, sin) of float64 phases in float32 as the merges and the final stage evaluate
// it (carrier::cos_sin_f32, backprojection's too; for tests).
void carrier_values(in<double, 1> ph, out<float, 1> c, out<float, 1> s) {
  const std::size_t n = ph.shape(0);
  if (c.shape(0) != n || s.shape(0) != n) throw nb::value_error("carrier_values: shapes");
  carrier_run(ph.data(), n, c.data(), s.data());
}

template void weights_of<float>(int, in<float, 1>, in<float, 2>, out<float, 2>);
template void weights_of<double>(int, in<double, 1>, in<double, 2>, out<double, 2>);

}  // namespace sarcli
