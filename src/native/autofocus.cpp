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
// in double precision, with E = Σ I and T = Σ I ln I (α = 1) or Σ I^α. The caller forms the
// entropy and its gradient from these (they are linear in the pixels, so the parts of a split
// grid add). Each tile's sums are kept apart and added in tile order: the result does not depend
// on the number of threads.
#include <algorithm>
#include <cmath>
#include <complex>
#include <vector>

#include <nanobind/stl/optional.h>
#include <nanobind/stl/tuple.h>

#include "sarcli_simd.hpp"

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
               std::size_t m, double alpha, bool grad, float* fa, float* fb, double* h, double* res) {
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
  // xa = (Re f, Im f)·a and xb = (-Im f, Re f)·a; Y_b likewise without a
  double* xa = h;
  double* xb = h + m2;
  double* ya = h + 2 * m2;
  double* yb = h + 3 * m2;
  double E = 0.0, T = 0.0;
  const bool shannon = alpha == 1.0;
  for (std::size_t s = 0; s < m; ++s) {
    const double fr = static_cast<double>(fa[2 * s] - fb[2 * s + 1]);
    const double fi = static_cast<double>(fa[2 * s + 1] + fb[2 * s]);
    const double I = fr * fr + fi * fi;
    double a = 0.0;
    if (I > 0.0) {
      a = shannon ? std::log(I) : std::pow(I, alpha - 1.0);
      T += I * a;
      E += I;
    }
    xa[2 * s] = fr * a;
    xa[2 * s + 1] = fi * a;
    xb[2 * s] = -fi * a;
    xb[2 * s + 1] = fr * a;
    ya[2 * s] = fr;
    ya[2 * s + 1] = fi;
    yb[2 * s] = -fi;
    yb[2 * s + 1] = fr;
  }
  res[0] = E;
  res[1] = T;
  if (!grad) return;
  for (std::size_t b = 0; b < nb; ++b) {
    const float* p = stack + 2 * (b * n + s0);
    double sa = 0.0, sb = 0.0, ta = 0.0, tb = 0.0;
#pragma omp simd reduction(+ : sa, sb, ta, tb)
    for (std::size_t k = 0; k < m2; ++k) {
      const double v = p[k];
      sa += v * xa[k];
      sb += v * xb[k];
      ta += v * ya[k];
      tb += v * yb[k];
    }
    double* r = res + 2 + 4 * b;
    r[0] = sa;
    r[1] = sb;
    r[2] = ta;
    r[3] = tb;
  }
}

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
      std::vector<double> h(8 * tile);
#pragma omp for schedule(static)
      for (long t = 0; t < static_cast<long>(ntiles); ++t) {
        const std::size_t s0 = static_cast<std::size_t>(t) * tile;
        tile_sums(sp, n, nbk, ep, s0, std::min(tile, n - s0), alpha, grad, fa.data(), fb.data(), h.data(),
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

}  // namespace
}  // namespace sarcli

NB_MODULE(_autofocus, m) {
  using namespace nanobind::literals;
  namespace s = sarcli;
  m.doc() = "Entropy sums of a sub-aperture image stack and, fused, those of its gradient.";
  m.def("entropy_sums", &s::entropy_sums, "stack"_a, "e"_a, "alpha"_a, "x"_a.noconvert().none(),
        "y"_a.noconvert().none(),
        "(E, T) of f = e @ stack: E = Σ|f|², T = Σ I ln I (alpha = 1) or Σ I^alpha; with x, y "
        "(complex128, one per image) also X_b = Σ_s stack[b,s] conj(f_s) a_s (a = ln I or "
        "I^(alpha-1), 0 where I = 0) and Y_b = Σ_s stack[b,s] conj(f_s).");
}
