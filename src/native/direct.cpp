// The exact spherical-wave matched filter's sum (sarcli.formers.direct): every pulse and
// frequency at every pixel, each term's phase in float64 and its own cosine and sine.
//
// The cosine and sine are Cephes' (Moshier) polynomials on [-π/4, π/4] after a three-part
// Cody–Waite reduction by π/2, evaluated without branches so that a group of pixels runs as one
// vector: within 2 ulp of the correctly rounded values for |phase| < kExactArg (tested against
// the C library), beyond which a pulse's terms come from the C library's sin and cos.
#include <cmath>
#include <complex>
#include <cstring>
#include <vector>
#include <algorithm>

#include <nanobind/stl/pair.h>

#include "sarcli_simd.hpp"

namespace sarcli {
namespace {

using cplx = std::complex<double>;
constexpr std::size_t kPix = 8;  // pixels summed together (one read of each weight per group)
constexpr double kExactArg = 1e8;  // |phase| up to which sin_cos is used (reduction exact to 2^29 π/2)

// sin x and cos x: x = q π/2 + r with |r| <= π/4, then the quadrant q mod 4 picks and signs the
// polynomials. π/2 = 2 (DP1 + DP2 + DP3), each part 24 bits, so q DPi is exact for |q| < 2^29.
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

// out[n] += Σ_p Σ_j wd[p, j] exp(i k4[p, j] dr[p, n]) for the pixels n0 <= n < n1; each pixel's
// terms are added in pulse-major order. kmax[p] = max_j |k4[p, j]|.
SARCLI_CLONES
void pixel_group(const double* dr, std::size_t n_pix, const double* k4, const double* kmax,
                 const cplx* wd, std::size_t P, std::size_t M, std::size_t n0, std::size_t n1,
                 cplx* out) {
  const std::size_t m = n1 - n0;
  double re[kPix] = {}, im[kPix] = {}, r[kPix] = {};
  for (std::size_t p = 0; p < P; ++p) {
    double rmax = 0.0;
    for (std::size_t l = 0; l < kPix; ++l) {  // lanes past n1 sum terms of phase 0, never stored
      r[l] = l < m ? dr[p * n_pix + n0 + l] : 0.0;
      rmax = std::max(rmax, std::abs(r[l]));
    }
    const double* kp = k4 + p * M;
    const cplx* wp = wd + p * M;
    if (kmax[p] * rmax < kExactArg) {
      for (std::size_t j = 0; j < M; ++j) {
        const double k = kp[j], wr = wp[j].real(), wi = wp[j].imag();
        for (std::size_t l = 0; l < kPix; ++l) {
          double sn, cs;
          sin_cos(k * r[l], sn, cs);
          re[l] += wr * cs - wi * sn;
          im[l] += wr * sn + wi * cs;
        }
      }
    } else {
      for (std::size_t j = 0; j < M; ++j) {
        const double k = kp[j], wr = wp[j].real(), wi = wp[j].imag();
        for (std::size_t l = 0; l < kPix; ++l) {
          const double ph = k * r[l];
          const double cs = std::cos(ph), sn = std::sin(ph);
          re[l] += wr * cs - wi * sn;
          im[l] += wr * sn + wi * cs;
        }
      }
    }
  }
  for (std::size_t l = 0; l < m; ++l) out[n0 + l] += cplx(re[l], im[l]);
}

void accumulate_spherical(out<cplx, 1> out, in<double, 2> dr, in<double, 2> k4, in<cplx, 2> wd) {
  const std::size_t P = dr.shape(0), n_pix = dr.shape(1), M = k4.shape(1);
  if (k4.shape(0) != P || wd.shape(0) != P || wd.shape(1) != M || out.shape(0) != n_pix)
    throw nb::value_error("accumulate_spherical: inconsistent shapes");
  const double *pd = dr.data(), *pk = k4.data();
  const cplx* pw = wd.data();
  cplx* po = out.data();
  const long groups = static_cast<long>((n_pix + kPix - 1) / kPix);
  nb::gil_scoped_release nogil;
  std::vector<double> kmax(P, 0.0);
  for (std::size_t p = 0; p < P; ++p)
    for (std::size_t j = 0; j < M; ++j) kmax[p] = std::max(kmax[p], std::abs(pk[p * M + j]));
#pragma omp parallel for schedule(static)
  for (long q = 0; q < groups; ++q) {
    const std::size_t n0 = static_cast<std::size_t>(q) * kPix;
    pixel_group(pd, n_pix, pk, kmax.data(), pw, P, M, n0, n0 + kPix <= n_pix ? n0 + kPix : n_pix, po);
  }
}

SARCLI_CLONES
void sin_cos_n(const double* x, std::size_t n, double* s, double* c) {
  for (std::size_t i = 0; i < n; ++i) sin_cos(x[i], s[i], c[i]);
}

// sin and cos of every x by the kernel's instruction set (tests of sin_cos against the C library).
std::pair<nb::ndarray<nb::numpy, double, nb::ndim<1>>, nb::ndarray<nb::numpy, double, nb::ndim<1>>>
sin_cos_array(in<double, 1> x) {
  const std::size_t n = x.shape(0);
  double* s = new double[n];
  double* c = new double[n];
  sin_cos_n(x.data(), n, s, c);
  nb::capsule fs(s, [](void* p) noexcept { delete[] static_cast<double*>(p); });
  nb::capsule fc(c, [](void* p) noexcept { delete[] static_cast<double*>(p); });
  return {nb::ndarray<nb::numpy, double, nb::ndim<1>>(s, {n}, fs),
          nb::ndarray<nb::numpy, double, nb::ndim<1>>(c, {n}, fc)};
}

}  // namespace
}  // namespace sarcli

NB_MODULE(_direct, m) {
  using namespace nanobind::literals;
  m.doc() = "The exact matched filter's spherical-wave sum (float64 phases).";
  m.def("accumulate_spherical", &sarcli::accumulate_spherical, "out"_a.noconvert(), "dr"_a, "k4"_a,
        "wd"_a,
        "out[n] += sum_p sum_j wd[p, j] exp(i k4[p, j] dr[p, n]); out (n_pix,), dr (P, n_pix), "
        "k4 (P, M) float64, wd (P, M) complex128.");
  m.def("sin_cos", &sarcli::sin_cos_array, "x"_a,
        "(sin x, cos x) by the kernel's own polynomials (valid for |x| < 1e8).");
}
