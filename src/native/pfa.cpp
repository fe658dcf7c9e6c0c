// The polar format algorithm's gridding step (sarcli.formers.pfa): spread every sample onto the
// Cartesian k-grid with its separable kernel, the taps evaluated here.
//
// Threads own bands of grid rows and each walks all samples, adding only the taps that fall in
// its rows, so every cell receives its contributions in sample order: the result is the same for
// any number of threads, with no atomics and no private copies of the grid.
#include <algorithm>
#include <cmath>
#include <complex>
#include <cstring>
#include <string>


#include <omp.h>

#include "pfa.hpp"
#include "sarcli_simd.hpp"

namespace sarcli {
namespace {

using cplx = std::complex<double>;
using v8d = double __attribute__((vector_size(64)));
constexpr int kMaxWidth = 16;

// The modified Bessel function I0 by Cephes' Chebyshev expansions (Moshier), those of numpy.i0
// and scipy.special.i0: exp(x) chbevl(x/2 - 2, A) for x <= 8, exp(x) chbevl(32/x - 2, B) / sqrt(x)
// beyond.
constexpr double kI0A[30] = {
    -4.41534164647933937950E-18, 3.33079451882223809783E-17, -2.43127984654795469359E-16,
    1.71539128555513303061E-15, -1.16853328779934516808E-14, 7.67618549860493561688E-14,
    -4.85644678311192946090E-13, 2.95505266312963983461E-12, -1.72682629144155570723E-11,
    9.67580903537323691224E-11, -5.18979560163526290666E-10, 2.65982372468238665035E-9,
    -1.30002500998624804212E-8, 6.04699502254191894932E-8, -2.67079385394061173391E-7,
    1.11738753912010371815E-6, -4.41673835845875056359E-6, 1.64484480707288970893E-5,
    -5.75419501008210370398E-5, 1.88502885095841655729E-4, -5.76375574538582365885E-4,
    1.63947561694133579842E-3, -4.32430999505057594430E-3, 1.05464603945949983183E-2,
    -2.37374148058994688156E-2, 4.93052842396707084878E-2, -9.49010970480476444210E-2,
    1.71620901522208775349E-1, -3.04682672343198398683E-1, 6.76795274409476084995E-1};
constexpr double kI0B[25] = {
    -7.23318048787475395456E-18, -4.83050448594418207126E-18, 4.46562142029675999901E-17,
    3.46122286769746109310E-17, -2.82762398051658348494E-16, -3.42548561967721913462E-16,
    1.77256013305652638360E-15, 3.81168066935262242075E-15, -9.55484669882830764870E-15,
    -4.15056934728722208663E-14, 1.54008621752140982691E-14, 3.85277838274214270114E-13,
    7.18012445138366623367E-13, -1.79417853150680611778E-12, -1.32158118404477131188E-11,
    -3.14991652796324136454E-11, 1.18891471078464383424E-11, 4.94060238822496958910E-10,
    3.39623202570838634515E-9, 2.26666899049817806459E-8, 2.04891858946906374183E-7,
    2.89137052083475648297E-6, 6.88975834691682398426E-5, 3.36911647825569408990E-3,
    8.04490411014108831608E-1};

// exp(x) for 0 <= x < 700: Cephes' rational approximation (Moshier) after x = n ln2 + r, the
// power of two set in the exponent bits; no branches, so a loop over taps vectorises.
SARCLI_INLINE double exp_pos(double x) {
  constexpr double kLog2e = 1.4426950408889634073599, kShift = 6755399441055744.0;
  constexpr double C1 = 6.93145751953125e-1, C2 = 1.42860682030941723212e-6;
  const double t = x * kLog2e + kShift, n = t - kShift;
  std::uint64_t bits;
  std::memcpy(&bits, &t, sizeof bits);
  const double r = (x - n * C1) - n * C2, rr = r * r;
  const double p = r * ((1.26177193074810590878e-4 * rr + 3.02994407707441961300e-2) * rr +
                        9.99999999999999999910e-1);
  const double q = ((3.00198505138664455042e-6 * rr + 2.52448340349684104192e-3) * rr +
                    2.27265548208155028766e-1) * rr + 2.00000000000000000009e0;
  const double e = 1.0 + 2.0 * (p / (q - p));
  const std::uint64_t scale_bits = ((bits & 0xfff) + 1023) << 52;
  double scale;
  std::memcpy(&scale, &scale_bits, sizeof scale);
  return e * scale;
}

// First grid index of the kernel centred at the fractional index u.
SARCLI_INLINE std::int64_t first_index(double u, int w) {
  return static_cast<std::int64_t>(std::floor(u - w / 2.0)) + 1;
}

// Kaiser-Bessel taps I0(β sqrt(1 - (2 o / w)²)) at N offsets o (N a multiple of 8), both of
// I0's expansions evaluated on all lanes. Clenshaw's recurrence b_i = y b_(i-1) - b_(i-2) + c_i
// (value (b_n - b_(n-2)) / 2) runs on vectors of 8 lanes (GCC vector extensions: one register
// each in the AVX-512 clone, split in the others), the N / 4 chains interleaved.
template <int N>
SARCLI_INLINE void kaiser_bessel(const double* o, int w, double beta, double* t) {
  constexpr int NV = N / 8;
  alignas(64) double x[N], ya[N], yb[N], a0[N], a1[N], b0[N], b1[N];
  for (int a = 0; a < N; ++a) {
    const double q = 2.0 * o[a] / w;
    x[a] = beta * std::sqrt(std::max(1.0 - q * q, 0.0));
    ya[a] = x[a] / 2.0 - 2.0;                  // x <= 8
    yb[a] = 32.0 / std::max(x[a], 8.0) - 2.0;  // x > 8
  }
  v8d yav[NV], ybv[NV], a0v[NV], a1v[NV], b0v[NV], b1v[NV];
  std::memcpy(yav, ya, sizeof yav);
  std::memcpy(ybv, yb, sizeof ybv);
  for (int v = 0; v < NV; ++v) {
    a0v[v] = v8d{} + kI0A[0], a1v[v] = v8d{};
    b0v[v] = v8d{} + kI0B[0], b1v[v] = v8d{};
  }
  for (int i = 1; i < 24; ++i)
    for (int v = 0; v < NV; ++v) {
      const v8d pa = a0v[v], pb = b0v[v];
      a0v[v] = yav[v] * pa - a1v[v] + kI0A[i];
      b0v[v] = ybv[v] * pb - b1v[v] + kI0B[i];
      a1v[v] = pa;
      b1v[v] = pb;
    }
  for (int i = 24; i < 29; ++i)
    for (int v = 0; v < NV; ++v) {
      const v8d pa = a0v[v];
      a0v[v] = yav[v] * pa - a1v[v] + kI0A[i];
      a1v[v] = pa;
    }
  std::memcpy(a0, a0v, sizeof a0v);
  std::memcpy(a1, a1v, sizeof a1v);
  std::memcpy(b0, b0v, sizeof b0v);
  std::memcpy(b1, b1v, sizeof b1v);
  for (int a = 0; a < N; ++a) {
    const double ca = ya[a] * a0[a] - a1[a] + kI0A[29], cb = yb[a] * b0[a] - b1[a] + kI0B[24];
    const double cheb = x[a] <= 8.0 ? 0.5 * (ca - a1[a])
                                    : 0.5 * (cb - b1[a]) / std::sqrt(std::max(x[a], 8.0));
    t[a] = exp_pos(x[a]) * cheb;
  }
}

// The w taps along both axes of the kernel centred at (u, v), first indices (fx, fy), at the
// offsets first + a - u in (-w/2, w/2]: the tent max(0, 1 - |o|) or the Kaiser-Bessel kernel.
template <int L>
SARCLI_INLINE void taps_xy(double u, std::int64_t fx, double v, std::int64_t fy, bool linear, int w,
                           double beta, double* tx, double* ty) {
  alignas(64) double o[2 * L], t[2 * L];
  for (int a = 0; a < L; ++a) {
    o[a] = static_cast<double>(fx + a) - u;
    o[L + a] = static_cast<double>(fy + a) - v;
  }
  if (linear) {
    for (int a = 0; a < 2 * L; ++a) t[a] = std::max(0.0, 1.0 - std::abs(o[a]));
  } else {
    kaiser_bessel<2 * L>(o, w, beta, t);
  }
  std::copy(t, t + w, tx);
  std::copy(t + L, t + L + w, ty);
}

SARCLI_INLINE void taps_xy(double u, std::int64_t fx, double v, std::int64_t fy, bool linear, int w,
                           double beta, double* tx, double* ty) {
  if (w <= 4)
    taps_xy<4>(u, fx, v, fy, linear, w, beta, tx, ty);
  else if (w <= 8)
    taps_xy<8>(u, fx, v, fy, linear, w, beta, tx, ty);
  else
    taps_xy<kMaxWidth>(u, fx, v, fy, linear, w, beta, tx, ty);
}

// grid[fy + b, fx + a] += c[s] ty[b] tx[a] for every sample s, for the rows r0 <= fy + b < r1.
SARCLI_CLONES
void spread_rows(cplx* grid, std::size_t nkx, const double* u, const double* v, const cplx* c,
                 std::size_t S, bool linear, int w, double beta, std::int64_t r0, std::int64_t r1) {
  alignas(64) double tx[kMaxWidth], ty[kMaxWidth];
  for (std::size_t s = 0; s < S; ++s) {
    const std::int64_t fy = first_index(v[s], w);
    if (fy >= r1 || fy + w <= r0) continue;
    const std::int64_t fx = first_index(u[s], w);
    taps_xy(u[s], fx, v[s], fy, linear, w, beta, tx, ty);
    const int b0 = fy < r0 ? static_cast<int>(r0 - fy) : 0;
    const int b1 = static_cast<int>(std::min<std::int64_t>(w, r1 - fy));
    const double cr = c[s].real(), ci = c[s].imag();
    for (int b = b0; b < b1; ++b) {
      const double vr = cr * ty[b], vi = ci * ty[b];
      double* row = reinterpret_cast<double*>(grid + static_cast<std::size_t>(fy + b) * nkx + fx);
      for (int a = 0; a < w; ++a) {
        row[2 * a] += vr * tx[a];
        row[2 * a + 1] += vi * tx[a];
      }
    }
  }
}

}  // namespace

void spread(out<cplx, 2> grid, in<double, 1> u, in<double, 1> v, in<cplx, 1> c,
            const std::string& kernel, int width, double beta) {
  const std::size_t S = c.shape(0);
  const std::int64_t nky = static_cast<std::int64_t>(grid.shape(0)), nkx = static_cast<std::int64_t>(grid.shape(1));
  if (u.shape(0) != S || v.shape(0) != S) throw nb::value_error("spread: inconsistent shapes");
  if (kernel != "kaiser" && kernel != "linear") throw nb::value_error("spread: kernel must be 'kaiser' or 'linear'");
  if (width < 1 || width > kMaxWidth) throw nb::value_error("spread: width must be 1..16");
  const double *pu = u.data(), *pv = v.data();
  for (std::size_t s = 0; s < S; ++s) {
    if (!(std::isfinite(pu[s]) && std::isfinite(pv[s])))
      throw nb::value_error("spread: a sample's position is not finite");
    const std::int64_t fx = first_index(pu[s], width), fy = first_index(pv[s], width);
    if (fx < 0 || fx + width > nkx || fy < 0 || fy + width > nky)
      throw nb::value_error("spread: a sample's kernel reaches outside the grid");
  }
  const bool linear = kernel == "linear";
  const cplx* pc = c.data();
  cplx* pg = grid.data();
  nb::gil_scoped_release nogil;
#pragma omp parallel if (S * width >= (1u << 12))
  {
    const std::int64_t T = omp_get_num_threads(), t = omp_get_thread_num();
    spread_rows(pg, static_cast<std::size_t>(nkx), pu, pv, pc, S, linear, width, beta, nky * t / T,
                nky * (t + 1) / T);
  }
}

namespace {

SARCLI_CLONES
void taps_n(const double* u, std::size_t S, bool linear, int w, double beta, std::int64_t* first,
            double* t) {
  for (std::size_t s = 0; s < S; ++s) {
    first[s] = first_index(u[s], w);
    double unused[kMaxWidth];
    taps_xy(u[s], first[s], u[s], first[s], linear, w, beta, t + s * w, unused);
  }
}

}  // namespace

// The taps of every sample by the kernel's instruction set (tests against the NumPy formulas).
void kernel_taps(in<double, 1> u, const std::string& kernel, int width, double beta,
                 out<std::int64_t, 1> first, out<double, 2> t) {
  const std::size_t S = u.shape(0);
  if (width < 1 || width > kMaxWidth || first.shape(0) != S || t.shape(0) != S ||
      t.shape(1) != static_cast<std::size_t>(width))
    throw nb::value_error("kernel_taps: inconsistent shapes");
  taps_n(u.data(), S, kernel == "linear", width, beta, first.data(), t.data());
}

}  // namespace sarcli
