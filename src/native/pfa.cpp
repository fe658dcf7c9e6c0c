// The polar format algorithm's gridding step (sarcli.formers.pfa): spread every sample onto the
// Cartesian k-grid with its separable kernel taps.
//
// Threads own bands of grid rows and each walks all samples, adding only the taps that fall in
// its rows, so every cell receives its contributions in sample order: the result is the same for
// any number of threads, with no atomics and no private copies of the grid.
#include <algorithm>
#include <complex>

#include <omp.h>

#include "sarcli_simd.hpp"

namespace sarcli {
namespace {

using cplx = std::complex<double>;

// grid[fy[s] + b, fx[s] + a] += c[s] ty[s, b] tx[s, a] for the rows r0 <= fy[s] + b < r1.
SARCLI_CLONES
void spread_rows(cplx* grid, std::size_t nkx, const std::int64_t* fx, const std::int64_t* fy,
                 const double* tx, const double* ty, const cplx* c, std::size_t S, std::size_t wx,
                 std::size_t wy, std::int64_t r0, std::int64_t r1) {
  for (std::size_t s = 0; s < S; ++s) {
    const std::int64_t f = fy[s];
    if (f >= r1 || f + static_cast<std::int64_t>(wy) <= r0) continue;
    const std::size_t b0 = f < r0 ? static_cast<std::size_t>(r0 - f) : 0;
    const std::size_t b1 = std::min<std::int64_t>(static_cast<std::int64_t>(wy), r1 - f);
    const double* txs = tx + s * wx;
    const double cr = c[s].real(), ci = c[s].imag();
    for (std::size_t b = b0; b < b1; ++b) {
      const double t = ty[s * wy + b];
      const double vr = cr * t, vi = ci * t;
      double* row = reinterpret_cast<double*>(grid + static_cast<std::size_t>(f + b) * nkx + fx[s]);
      for (std::size_t a = 0; a < wx; ++a) {
        row[2 * a] += vr * txs[a];
        row[2 * a + 1] += vi * txs[a];
      }
    }
  }
}

void spread(out<cplx, 2> grid, in<std::int64_t, 1> fx, in<std::int64_t, 1> fy, in<double, 2> tx,
            in<double, 2> ty, in<cplx, 1> c) {
  const std::size_t S = c.shape(0), wx = tx.shape(1), wy = ty.shape(1);
  const std::int64_t nky = static_cast<std::int64_t>(grid.shape(0)), nkx = static_cast<std::int64_t>(grid.shape(1));
  if (fx.shape(0) != S || fy.shape(0) != S || tx.shape(0) != S || ty.shape(0) != S)
    throw nb::value_error("spread: inconsistent shapes");
  const std::int64_t *px = fx.data(), *py = fy.data();
  for (std::size_t s = 0; s < S; ++s)
    if (px[s] < 0 || px[s] + static_cast<std::int64_t>(wx) > nkx || py[s] < 0 ||
        py[s] + static_cast<std::int64_t>(wy) > nky)
      throw nb::value_error("spread: a sample's kernel reaches outside the grid");
  const double *ptx = tx.data(), *pty = ty.data();
  const cplx* pc = c.data();
  cplx* pg = grid.data();
  nb::gil_scoped_release nogil;
#pragma omp parallel if (S * wx * wy > (1u << 16))
  {
    const std::int64_t T = omp_get_num_threads(), t = omp_get_thread_num();
    spread_rows(pg, static_cast<std::size_t>(nkx), px, py, ptx, pty, pc, S, wx, wy, nky * t / T,
                nky * (t + 1) / T);
  }
}

}  // namespace
}  // namespace sarcli

NB_MODULE(_pfa, m) {
  using namespace nanobind::literals;
  m.doc() = "The polar format algorithm's gridding (spreading) loop.";
  m.def("spread", &sarcli::spread, "grid"_a.noconvert(), "fx"_a, "fy"_a, "tx"_a, "ty"_a, "c"_a,
        "grid[fy[s] + b, fx[s] + a] += c[s] ty[s, b] tx[s, a]; grid (nky, nkx) complex128, fx, fy "
        "(S,) int64 first indices, tx (S, wx), ty (S, wy) float64 taps, c (S,) complex128.");
}
