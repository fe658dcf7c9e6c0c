// The simulator's exact spherical-model sum (sarcli.simulation): every point target's phasor at
// every pulse and frequency, in float64.
#include <cmath>
#include <complex>
#include <vector>

#include "simulate.hpp"
#include "sarcli_simd.hpp"

namespace sarcli {
namespace {

using cplx = std::complex<double>;
constexpr double kC = 299792458.0;  // sarcli.core.geometry.C
constexpr double kPi = 3.14159265358979323846;

// One pulse: acc[j] = Σ_s amp[s] exp(-i 4π f[j] Δr_s / c).
SARCLI_CLONES
void pulse_sum(const double* f, std::size_t M, const double* a, double offset, const double* xy,
               const cplx* amp, std::size_t S, cplx* acc) {
  const double ax = a[0], ay = a[1], az = a[2];
  const double na = std::sqrt(ax * ax + ay * ay + az * az);
  const double df = M > 1 ? f[1] - f[0] : 0.0;
  bool uniform = true;
  for (std::size_t j = 1; j < M; ++j)
    if (std::abs((f[j] - f[j - 1]) - df) > 1e-9 * std::abs(f[0])) { uniform = false; break; }
  for (std::size_t s = 0; s < S; ++s) {
    const double x = xy[2 * s], y = xy[2 * s + 1];
    const double xx = x * x + y * y, adot = ax * x + ay * y;
    const double dist = std::sqrt(na * na - 2.0 * adot + xx);
    const double dr = (xx - 2.0 * adot) / (dist + na) + offset;  // cancellation-free
    const double k0 = 4.0 * kPi * dr / kC;
    if (uniform) {
      // advance the phasor by multiplication, re-anchored every 64 steps (rounding < 1e-13)
      const cplx step = std::polar(1.0, -k0 * df);
      for (std::size_t j0 = 0; j0 < M; j0 += 64) {
        cplx z = amp[s] * std::polar(1.0, -k0 * f[j0]);
        const std::size_t j1 = j0 + 64 < M ? j0 + 64 : M;
        for (std::size_t j = j0; j < j1; ++j) { acc[j] += z; z *= step; }
      }
    } else {
      for (std::size_t j = 0; j < M; ++j) acc[j] += amp[s] * std::polar(1.0, -k0 * f[j]);
    }
  }
}

}  // namespace

void spherical_sum(in<double, 2> freq, in<double, 2> antenna, in<double, 1> offset,
                   in<double, 2> points_xy, in<cplx, 1> amp, out<cplx, 2> result) {
  const long P = static_cast<long>(freq.shape(0));
  const std::size_t M = freq.shape(1), S = points_xy.shape(0);
  if (antenna.shape(0) != freq.shape(0) || antenna.shape(1) != 3 || offset.shape(0) != freq.shape(0) ||
      points_xy.shape(1) != 2 || amp.shape(0) != S || result.shape(0) != freq.shape(0) ||
      result.shape(1) != M)
    throw nb::value_error("spherical_sum: inconsistent shapes");
  const double *f = freq.data(), *a = antenna.data(), *off = offset.data(), *xy = points_xy.data();
  const cplx* am = amp.data();
  cplx* o = result.data();
  nb::gil_scoped_release nogil;
#pragma omp parallel
  {
    std::vector<cplx> acc(M);
#pragma omp for schedule(static)
    for (long p = 0; p < P; ++p) {
      std::fill(acc.begin(), acc.end(), cplx(0.0, 0.0));
      pulse_sum(f + p * M, M, a + 3 * p, off[p], xy, am, S, acc.data());
      for (std::size_t j = 0; j < M; ++j) o[p * M + j] += acc[j];
    }
  }
}

}  // namespace sarcli
