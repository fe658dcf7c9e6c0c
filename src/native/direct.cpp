// The exact spherical-wave matched filter's sum (sarcli.formers.direct): every pulse and
// frequency at every pixel, the phase in float64 and its cosine and sine from the C library.
#include <cmath>
#include <complex>

#include "sarcli_simd.hpp"

namespace sarcli {
namespace {

using cplx = std::complex<double>;
constexpr std::size_t kPix = 8;  // pixels summed together (one read of each weight per group)

// out[n] += Σ_p Σ_j wd[p, j] exp(i k4[p, j] dr[p, n]) for the pixels n0 <= n < n1; each pixel's
// terms are added in pulse-major order.
SARCLI_CLONES
void pixel_group(const double* dr, std::size_t n_pix, const double* k4, const cplx* wd,
                 std::size_t P, std::size_t M, std::size_t n0, std::size_t n1, cplx* out) {
  const std::size_t m = n1 - n0;
  double re[kPix] = {}, im[kPix] = {}, r[kPix] = {};
  for (std::size_t p = 0; p < P; ++p) {
    for (std::size_t l = 0; l < m; ++l) r[l] = dr[p * n_pix + n0 + l];
    const double* kp = k4 + p * M;
    const cplx* wp = wd + p * M;
    for (std::size_t j = 0; j < M; ++j) {
      const double k = kp[j], wr = wp[j].real(), wi = wp[j].imag();
      for (std::size_t l = 0; l < m; ++l) {
        const double ph = k * r[l];
        const double cs = std::cos(ph), sn = std::sin(ph);
        re[l] += wr * cs - wi * sn;
        im[l] += wr * sn + wi * cs;
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
#pragma omp parallel for schedule(static)
  for (long q = 0; q < groups; ++q) {
    const std::size_t n0 = static_cast<std::size_t>(q) * kPix;
    pixel_group(pd, n_pix, pk, pw, P, M, n0, n0 + kPix <= n_pix ? n0 + kPix : n_pix, po);
  }
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
}
