// The polar format algorithm's gridding step (sarcli.formers.pfa): spread every sample onto the
// Cartesian k-grid with its separable kernel, the taps evaluated here.
//
// Threads own bands of grid rows and each walks all samples, adding only the taps that fall in
// its rows, so every cell receives its contributions in sample order: the result is the same for
// any number of threads, with no atomics and no private copies of the grid.
#include <algorithm>
#include <cmath>
#include <complex>
#include <string>

#include <nanobind/stl/string.h>

#include <omp.h>

#include "sarcli_simd.hpp"

namespace sarcli {
namespace {

using cplx = std::complex<double>;
constexpr int kMaxWidth = 16;

// Modified Bessel function I0: Cephes' Chebyshev expansions (Moshier), as in numpy.i0 and
// scipy.special.i0.
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

SARCLI_INLINE double chbevl(double x, const double* c, int n) {
  double b0 = c[0], b1 = 0.0, b2 = 0.0;
  for (int i = 1; i < n; ++i) {
    b2 = b1;
    b1 = b0;
    b0 = x * b1 - b2 + c[i];
  }
  return 0.5 * (b0 - b2);
}

SARCLI_INLINE double bessel_i0(double x) {
  x = std::abs(x);
  if (x <= 8.0) return std::exp(x) * chbevl(x / 2.0 - 2.0, kI0A, 30);
  return std::exp(x) * chbevl(32.0 / x - 2.0, kI0B, 25) / std::sqrt(x);
}

// First grid index of the kernel centred at the fractional index u, and its w taps:
// Kaiser-Bessel I0(β sqrt(1 - (2 o / w)²)) or the tent max(0, 1 - |o|) at the offsets
// o = first + a - u in (-w/2, w/2].
SARCLI_INLINE std::int64_t first_index(double u, int w) {
  return static_cast<std::int64_t>(std::floor(u - w / 2.0)) + 1;
}

SARCLI_INLINE void taps(double u, std::int64_t first, bool linear, int w, double beta, double* t) {
  for (int a = 0; a < w; ++a) {
    const double o = static_cast<double>(first + a) - u;
    if (linear) {
      t[a] = std::max(0.0, 1.0 - std::abs(o));
    } else {
      const double q = 2.0 * o / w;
      t[a] = bessel_i0(beta * std::sqrt(std::max(1.0 - q * q, 0.0)));
    }
  }
}

// grid[fy + b, fx + a] += c[s] ty[b] tx[a] for every sample s, for the rows r0 <= fy + b < r1.
SARCLI_CLONES
void spread_rows(cplx* grid, std::size_t nkx, const double* u, const double* v, const cplx* c,
                 std::size_t S, bool linear, int w, double beta, std::int64_t r0, std::int64_t r1) {
  double tx[kMaxWidth], ty[kMaxWidth];
  for (std::size_t s = 0; s < S; ++s) {
    const std::int64_t fy = first_index(v[s], w);
    if (fy >= r1 || fy + w <= r0) continue;
    const std::int64_t fx = first_index(u[s], w);
    taps(u[s], fx, linear, w, beta, tx);
    taps(v[s], fy, linear, w, beta, ty);
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

// The taps of every sample (for tests against the NumPy formulas).
void kernel_taps(in<double, 1> u, const std::string& kernel, int width, double beta,
                 out<std::int64_t, 1> first, out<double, 2> t) {
  const std::size_t S = u.shape(0);
  if (width < 1 || width > kMaxWidth || first.shape(0) != S || t.shape(0) != S ||
      t.shape(1) != static_cast<std::size_t>(width))
    throw nb::value_error("kernel_taps: inconsistent shapes");
  for (std::size_t s = 0; s < S; ++s) {
    first.data()[s] = first_index(u.data()[s], width);
    taps(u.data()[s], first.data()[s], kernel == "linear", width, beta, t.data() + s * width);
  }
}

}  // namespace
}  // namespace sarcli

NB_MODULE(_pfa, m) {
  using namespace nanobind::literals;
  m.doc() = "The polar format algorithm's gridding (spreading) loop.";
  m.def("spread", &sarcli::spread, "grid"_a.noconvert(), "u"_a, "v"_a, "c"_a, "kernel"_a, "width"_a,
        "beta"_a,
        "grid[fy + b, fx + a] += c[s] ty[b] tx[a] with the kernel ('kaiser' of shape beta, or "
        "'linear') of width cells centred at the fractional grid indices (u[s], v[s]); grid "
        "(nky, nkx) complex128.");
  m.def("kernel_taps", &sarcli::kernel_taps, "u"_a, "kernel"_a, "width"_a, "beta"_a,
        "first"_a.noconvert(), "taps"_a.noconvert(),
        "First grid index and taps of the kernel centred at each fractional index u.");
}
