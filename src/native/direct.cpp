// The exact spherical-wave matched filter's sum (sarcli.formers.direct): every pulse and
// frequency at every pixel, each term's phase in float64 and its own cosine and sine.
//
// The cosine and sine are the kernels' float64 ones (numerics/sincos.hpp: Cephes' polynomials,
// evaluated without branches so that a group of pixels runs as one vector), within 2 ulp of the
// correctly rounded values for |phase| < kExactArg (tested against the C library), beyond which
// a pulse's terms come from the C library's sin and cos.
#include <cmath>
#include <complex>
#include <cstring>
#include <vector>
#include <algorithm>


#include "numerics/sincos.hpp"
#include "direct.hpp"
#include "sarcli_simd.hpp"

namespace sarcli {
namespace {

using cplx = std::complex<double>;
constexpr std::size_t kPix = 8;  // pixels summed together (one read of each weight per group)
using carrier::kExactArg;  // |phase| up to which carrier::sin_cos holds its accuracy
using carrier::sin_cos;

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

}  // namespace

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

namespace {

SARCLI_CLONES
void sin_cos_n(const double* x, std::size_t n, double* s, double* c) {
  for (std::size_t i = 0; i < n; ++i) sin_cos(x[i], s[i], c[i]);
}

}  // namespace

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

}  // namespace sarcli
