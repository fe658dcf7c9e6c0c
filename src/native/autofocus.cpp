// Minimum-entropy autofocus on a stack of sub-aperture images (sarcli.autofocus._imager): one
// pass over the stack gives the image f = Σ_b e_b F_b's entropy sums and, fused with it, the
// per-sub-aperture sums its gradient needs, so the stack is read from memory once per evaluation.
//
// The pixels are taken in tiles whose rows of the stack stay in cache: the tile's image is summed
// over the sub-apertures (single precision, as the stack), then each pixel's intensity I = |f|²
// and weight a (ln I for Shannon's entropy, I^(α-1) for Rényi's of order α; 0 where I = 0), and
// the same rows are read again for
//
//   X_b = Σ_s F_bs conj(f_s) a_s,   Y_b = Σ_s F_bs conj(f_s)
//
// (single precision within a tile, where each vector lane sums a few dozen terms; double across
// tiles), with E = Σ I and T = Σ I ln I (α = 1) or Σ I^α in double. The caller forms the
// entropy and its gradient from these (they are linear in the pixels, so the parts of a split
// grid add). Each tile's sums are kept apart and added in tile order: the result does not depend
// on the number of threads.
//
// point_signals: each pulse's matched filter at a few points (phase gradient autofocus), by
// Horner's scheme in the phasor of the frequency step instead of one exponential per sample.
#include <algorithm>
#include <cmath>
#include <complex>
#include <vector>


#include "autofocus.hpp"
#include "sarcli_simd.hpp"

#if defined(SARCLI_HAVE_MVEC) && defined(__GNUC__) && !defined(__clang__)
// glibc's vector math library (libmvec): declared vectorisable, these calls in `omp simd` loops
// become its AVX-512, AVX2 or SSE variants in the matching clone
extern "C" double log(double) noexcept __attribute__((simd("notinbranch")));
extern "C" double pow(double, double) noexcept __attribute__((simd("notinbranch")));
#endif

namespace sarcli {
namespace {

using cf = std::complex<float>;
using cd = std::complex<double>;
constexpr std::size_t kTileBytes = 192 * 1024;  // stack bytes one tile reads (within a core's L2)

// One tile of pixels [s0, s0 + m): writes res = {E, T, X_0.re, X_0.im, Y_0.re, Y_0.im, ...}.
// Every inner loop runs over the tile's interleaved (re, im) values, contiguous: the image as
// Σ er·F + Σ ei·F (recombined per pixel), each complex sum as two real ones against the weights
// interleaved as (wr, wi) and (wi, wr).
SARCLI_CLONES
void tile_sums(const float* stack, std::size_t n, std::size_t nb, const float* e, std::size_t s0,
               std::size_t m, double alpha, bool grad, float* fa, float* fb, float* w, double* h, double* res) {
  const std::size_t m2 = 2 * m;
  std::fill(fa, fa + m2, 0.0f);
  std::fill(fb, fb + m2, 0.0f);
  for (std::size_t b = 0; b < nb; ++b) {
    const float er = e[2 * b], ei = e[2 * b + 1];
    const float* p = stack + 2 * (b * n + s0);
    // the next tile's part of this row follows this one: ask for it now (the rows are too many
    // streams for the hardware prefetcher)
    if (s0 + m < n)
      for (std::size_t k = 0; k < std::min(m2, 2 * (n - s0 - m)); k += 16)
        __builtin_prefetch(p + m2 + k, 0, 2);
    for (std::size_t k = 0; k < m2; ++k) {
      fa[k] += er * p[k];
      fb[k] += ei * p[k];
    }
  }
  // X_b = Σ_k p_k xa_k + i Σ_k p_k xb_k over the interleaved values p = (Re F, Im F), with
  // xa = (Re f, Im f)·a and xb = (-Im f, Re f)·a; Y_b likewise without a (ya, yb). Three loops
  // over the tile's pixels, each vectorised: the image and intensity, the weight (the logarithm or
  // power by glibc's vector math library where it is linked), the weighted values.
  float* xa = w;
  float* xb = w + m2;
  float* ya = w + 2 * m2;
  float* yb = w + 3 * m2;
  double* I = h;   // intensity per pixel, then the weight a per value (a, a)
  double* a2 = h + m2;
#pragma omp simd
  for (std::size_t s = 0; s < m; ++s) {
    const double fr = static_cast<double>(fa[2 * s] - fb[2 * s + 1]);
    const double fi = static_cast<double>(fa[2 * s + 1] + fb[2 * s]);
    I[s] = fr * fr + fi * fi;
    ya[2 * s] = static_cast<float>(fr);
    ya[2 * s + 1] = static_cast<float>(fi);
    yb[2 * s] = static_cast<float>(-fi);
    yb[2 * s + 1] = static_cast<float>(fr);
  }
  double E = 0.0, T = 0.0;
  if (alpha == 1.0) {
#pragma omp simd reduction(+ : E, T)
    for (std::size_t s = 0; s < m; ++s) {
      const double v = I[s];
      const double a = std::log(v > 0.0 ? v : 1.0);  // 0 where I = 0
      T += v * a;
      E += v;
      a2[2 * s] = a;
      a2[2 * s + 1] = a;
    }
  } else if (alpha == 0.5) {  // I^(-1/2): a square root, not a power
#pragma omp simd reduction(+ : E, T)
    for (std::size_t s = 0; s < m; ++s) {
      const double v = I[s];
      const double a = v > 0.0 ? 1.0 / std::sqrt(v) : 0.0;
      T += v * a;
      E += v;
      a2[2 * s] = a;
      a2[2 * s + 1] = a;
    }
  } else {
    const double am1 = alpha - 1.0;
#pragma omp simd reduction(+ : E, T)
    for (std::size_t s = 0; s < m; ++s) {
      const double v = I[s];
      const double a = v > 0.0 ? std::pow(v > 0.0 ? v : 1.0, am1) : 0.0;
      T += v * a;
      E += v;
      a2[2 * s] = a;
      a2[2 * s + 1] = a;
    }
  }
  res[0] = E;
  res[1] = T;
  if (!grad) return;
#pragma omp simd
  for (std::size_t k = 0; k < m2; ++k) {
    xa[k] = static_cast<float>(ya[k] * a2[k]);
    xb[k] = static_cast<float>(yb[k] * a2[k]);
  }
  // two rows at a time (the last one twice when they are odd in number): eight independent sums
  // share each load of the weights
  for (std::size_t b = 0; b < nb; b += 2) {
    const float* p = stack + 2 * (b * n + s0);
    const float* q = b + 1 < nb ? p + 2 * n : p;
    float sa = 0.0f, sb = 0.0f, ta = 0.0f, tb = 0.0f, ua = 0.0f, ub = 0.0f, va = 0.0f, vb = 0.0f;
#pragma omp simd reduction(+ : sa, sb, ta, tb, ua, ub, va, vb)
    for (std::size_t k = 0; k < m2; ++k) {
      const float v = p[k], u = q[k];
      sa += v * xa[k];
      sb += v * xb[k];
      ta += v * ya[k];
      tb += v * yb[k];
      ua += u * xa[k];
      ub += u * xb[k];
      va += u * ya[k];
      vb += u * yb[k];
    }
    double* r = res + 2 + 4 * b;
    r[0] = sa;
    r[1] = sb;
    r[2] = ta;
    r[3] = tb;
    if (b + 1 < nb) {
      r[4] = ua;
      r[5] = ub;
      r[6] = va;
      r[7] = vb;
    }
  }
}


}  // namespace

// (E, T); with x and y of length nb, X and Y written there.
nb::tuple entropy_sums(in<cf, 2> stack, in<cf, 1> e, double alpha, std::optional<out<cd, 1>> x,
                       std::optional<out<cd, 1>> y) {
  const std::size_t nbk = stack.shape(0), n = stack.shape(1);
  if (e.shape(0) != nbk) throw nb::value_error("entropy_sums: one phasor per sub-aperture image");
  const bool grad = x.has_value() && y.has_value();
  if (grad && (x->shape(0) != nbk || y->shape(0) != nbk))
    throw nb::value_error("entropy_sums: X and Y need one value per sub-aperture image");
  const std::size_t tile =
      std::max<std::size_t>(16, kTileBytes / (8 * std::max<std::size_t>(nbk, 1)) / 16 * 16);
  const std::size_t ntiles = (n + tile - 1) / tile;
  const std::size_t width = 2 + (grad ? 4 * nbk : 0);
  std::vector<double> res(ntiles * width, 0.0);
  const float* sp = reinterpret_cast<const float*>(stack.data());
  const float* ep = reinterpret_cast<const float*>(e.data());
  {
    nb::gil_scoped_release release;
#pragma omp parallel
    {
      std::vector<float> fa(2 * tile), fb(2 * tile);
      std::vector<float> w(8 * tile);
      std::vector<double> h(4 * tile);
#pragma omp for schedule(static)
      for (long t = 0; t < static_cast<long>(ntiles); ++t) {
        const std::size_t s0 = static_cast<std::size_t>(t) * tile;
        tile_sums(sp, n, nbk, ep, s0, std::min(tile, n - s0), alpha, grad, fa.data(), fb.data(), w.data(), h.data(),
                  res.data() + static_cast<std::size_t>(t) * width);
      }
    }
  }
  double E = 0.0, T = 0.0;
  for (std::size_t t = 0; t < ntiles; ++t) {
    E += res[t * width];
    T += res[t * width + 1];
  }
  if (grad) {
    cd* xp = x->data();
    cd* yp = y->data();
    for (std::size_t b = 0; b < nbk; ++b) {
      double s[4] = {0.0, 0.0, 0.0, 0.0};
      for (std::size_t t = 0; t < ntiles; ++t)
        for (int k = 0; k < 4; ++k) s[k] += res[t * width + 2 + 4 * b + k];
      xp[b] = cd(s[0], s[1]);
      yp[b] = cd(s[2], s[3]);
    }
  }
  return nb::make_tuple(E, T);
}

namespace {


// z[p, k] = (1/M) Σ_j d[p, j] e^{i κ_pj Δr_pk}: pulse p's matched filter at point k. With the
// least-squares line κ_pj = κ0 + j Δκ + δ_j through the pulse's wavenumbers, the sum is
// e^{i κ0 Δr} Σ_n (iΔr)^n / n! Σ_j d_j δ_j^n σ^j (σ = e^{iΔκ Δr}), the inner sums by Horner's
// scheme (vectorised over the points); four terms leave (δ Δr)^4 / 24 ≤ 4e-10 where
// max|δ| |Δr| ≤ 1e-2, and one serves where the wavenumbers lie on their line. A point beyond that
// bound is summed sample by sample.
SARCLI_CLONES
void point_signals_pulse(const cd* d, const double* kw, const double* dr, std::size_t M, std::size_t K,
                         cd* z, std::vector<double>& w) {
  // the line (least squares in j) and the deviations
  const double jm = 0.5 * static_cast<double>(M - 1);
  double sk = 0.0, sjk = 0.0, sjj = 0.0;
  for (std::size_t j = 0; j < M; ++j) {
    const double dj = static_cast<double>(j) - jm;
    sk += kw[j];
    sjk += dj * kw[j];
    sjj += dj * dj;
  }
  const double dk = sjj > 0.0 ? sjk / sjj : 0.0, k0 = sk / static_cast<double>(M) - jm * dk;
  double* dev = w.data();
  double dmax = 0.0;
  for (std::size_t j = 0; j < M; ++j) {
    dev[j] = kw[j] - (k0 + static_cast<double>(j) * dk);
    dmax = std::max(dmax, std::abs(dev[j]));
  }
  const int nord = dmax > 0.0 ? 4 : 1;
  double* sr = dev + M;       // σ's real and imaginary parts per point
  double* si = sr + K;
  double* ar = si + K;        // Horner accumulators [nord][K]
  double* ai = ar + 4 * K;
  for (std::size_t k = 0; k < K; ++k) {
    sr[k] = std::cos(dk * dr[k]);
    si[k] = std::sin(dk * dr[k]);
  }
  std::fill(ar, ar + 8 * K, 0.0);
  for (std::size_t jj = M; jj-- > 0;) {
    double cr = d[jj].real(), ci = d[jj].imag();
    for (int n = 0; n < nord; ++n) {
      double* __restrict xr = ar + n * K;
      double* __restrict xi = ai + n * K;
#pragma omp simd
      for (std::size_t k = 0; k < K; ++k) {
        const double tr = xr[k] * sr[k] - xi[k] * si[k] + cr;
        const double ti = xr[k] * si[k] + xi[k] * sr[k] + ci;
        xr[k] = tr;
        xi[k] = ti;
      }
      cr *= dev[jj];
      ci *= dev[jj];
    }
  }
  const double inv_m = 1.0 / static_cast<double>(M);
  for (std::size_t k = 0; k < K; ++k) {
    cd acc;
    if (dmax * std::abs(dr[k]) <= 1e-2) {
      cd f(1.0, 0.0);
      for (int n = 0; n < nord; ++n) {   // f = (iΔr)^n / n!
        acc += f * cd(ar[n * K + k], ai[n * K + k]);
        f *= cd(0.0, dr[k] / static_cast<double>(n + 1));
      }
      acc *= std::polar(1.0, k0 * dr[k]);
    } else {
      for (std::size_t j = 0; j < M; ++j) acc += d[j] * std::polar(1.0, kw[j] * dr[k]);
    }
    z[k] = acc * inv_m;
  }
}

}  // namespace

// point_signals(d [P, M], kw [P, M] two-way wavenumbers, dr [P, K] differential ranges, z [P, K]).
void point_signals(in<cd, 2> d, in<double, 2> kw, in<double, 2> dr, out<cd, 2> z) {
  const std::size_t P = d.shape(0), M = d.shape(1), K = dr.shape(1);
  if (kw.shape(0) != P || kw.shape(1) != M || dr.shape(0) != P || z.shape(0) != P || z.shape(1) != K)
    throw nb::value_error("point_signals: inconsistent shapes");
  if (M == 0 || K == 0) return;
  const cd* dp = d.data();
  const double* kp = kw.data();
  const double* rp = dr.data();
  cd* zp = z.data();
  nb::gil_scoped_release release;
#pragma omp parallel
  {
    std::vector<double> w(M + 10 * K);
#pragma omp for schedule(static)
    for (long p = 0; p < static_cast<long>(P); ++p)
      point_signals_pulse(dp + p * M, kp + p * M, rp + p * K, M, K, zp + p * K, w);
  }
}

}  // namespace sarcli
