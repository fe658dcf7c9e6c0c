// Streaming kernels of the linear operators and the ADMM solver (sarcli.linops._reduce): real
// inner products and squared norms of complex arrays, the fused shrinkage / multiplier update of
// ADMM, and periodic first differences of 2-D images (plain and phase-corrected).
//
// Every reduction reads its inputs once and allocates only its per-block partial sums. A complex
// array is summed as the float64 array of its real and imaginary parts, in blocks of kBlock
// values whose boundaries do not depend on the thread count; each block keeps 8 running sums
// (one per lane, so the loop vectorises without reassociation) combined in a fixed order, and
// the blocks' sums are added in block order. Results are therefore the same for any number of
// threads.
#include <cmath>
#include <complex>
#include <initializer_list>
#include <optional>
#include <string>
#include <vector>


#include "linops.hpp"
#include "sarcli_simd.hpp"

namespace sarcli {
namespace {

using cplx = std::complex<double>;
constexpr std::size_t kLanes = 8;
constexpr std::size_t kBlock = 1 << 14;  // float64 values per block (128 KiB per stream)
constexpr long kParallel = 16;           // blocks from which a call runs on several threads

SARCLI_INLINE double lane_sum(const double* acc) {
  return ((acc[0] + acc[4]) + (acc[2] + acc[6])) + ((acc[1] + acc[5]) + (acc[3] + acc[7]));
}

SARCLI_INLINE const double* dbl(const cplx* p) { return reinterpret_cast<const double*>(p); }
SARCLI_INLINE double* dbl(cplx* p) { return reinterpret_cast<double*>(p); }

// ---- reductions: each block worker adds into S sums -----------------------------------------

enum Kind { kRdot, kNorm2, kRdotDiff, kNorm2Diff, kRdotDiff2, kAddTwiceDiff, kStepDots };

// One block of n float64 values of the streams s[0..4]; sums written to res[0..].
SARCLI_CLONES
void block_sums(int kind, const double* const* s, double* v, std::size_t n, double* res) {
  double a0[kLanes] = {}, a1[kLanes] = {}, a2[kLanes] = {}, a3[kLanes] = {}, a4[kLanes] = {};
  const std::size_t nv = n - n % kLanes;
  const double *x = s[0], *y = s[1], *z = s[2], *u = s[3], *b = s[4];
  switch (kind) {
    case kRdot:  // Σ x y
      for (std::size_t i = 0; i < nv; i += kLanes)
        for (std::size_t l = 0; l < kLanes; ++l) a0[l] += x[i + l] * y[i + l];
      for (std::size_t i = nv; i < n; ++i) a0[i - nv] += x[i] * y[i];
      break;
    case kNorm2:  // Σ x²
      for (std::size_t i = 0; i < nv; i += kLanes)
        for (std::size_t l = 0; l < kLanes; ++l) a0[l] += x[i + l] * x[i + l];
      for (std::size_t i = nv; i < n; ++i) a0[i - nv] += x[i] * x[i];
      break;
    case kRdotDiff:  // Σ x (y - z)
      for (std::size_t i = 0; i < nv; i += kLanes)
        for (std::size_t l = 0; l < kLanes; ++l) a0[l] += x[i + l] * (y[i + l] - z[i + l]);
      for (std::size_t i = nv; i < n; ++i) a0[i - nv] += x[i] * (y[i] - z[i]);
      break;
    case kNorm2Diff:  // Σ (x - y)²
      for (std::size_t i = 0; i < nv; i += kLanes)
        for (std::size_t l = 0; l < kLanes; ++l) {
          const double d = x[i + l] - y[i + l];
          a0[l] += d * d;
        }
      for (std::size_t i = nv; i < n; ++i) a0[i - nv] += (x[i] - y[i]) * (x[i] - y[i]);
      break;
    case kRdotDiff2:  // Σ (x - y)(z - u)
      for (std::size_t i = 0; i < nv; i += kLanes)
        for (std::size_t l = 0; l < kLanes; ++l) a0[l] += (x[i + l] - y[i + l]) * (z[i + l] - u[i + l]);
      for (std::size_t i = nv; i < n; ++i) a0[i - nv] += (x[i] - y[i]) * (z[i] - u[i]);
      break;
    case kAddTwiceDiff:  // v ← 2 (x - y) + v, Σ v²
      for (std::size_t i = 0; i < nv; i += kLanes)
        for (std::size_t l = 0; l < kLanes; ++l) {
          const double w = 2.0 * (x[i + l] - y[i + l]) + v[i + l];
          v[i + l] = w;
          a0[l] += w * w;
        }
      for (std::size_t i = nv; i < n; ++i) {
        const double w = 2.0 * (x[i] - y[i]) + v[i];
        v[i] = w;
        a0[i - nv] += w * w;
      }
      break;
    case kStepDots:  // f = x, f_old = y, gf = z, gf_old = u, atb = b
      for (std::size_t i = 0; i < n; i += kLanes) {
        if (i + kLanes <= n) {
          for (std::size_t l = 0; l < kLanes; ++l) {
            const double f = x[i + l], d = f - y[i + l], g = z[i + l], e = g - u[i + l];
            a0[l] += f * f;
            a1[l] += d * d;
            a2[l] += d * e;
            a3[l] += f * g;
            a4[l] += f * b[i + l];
          }
        } else {
          for (std::size_t l = 0; i + l < n; ++l) {
            const double f = x[i + l], d = f - y[i + l], g = z[i + l], e = g - u[i + l];
            a0[l] += f * f;
            a1[l] += d * d;
            a2[l] += d * e;
            a3[l] += f * g;
            a4[l] += f * b[i + l];
          }
        }
      }
      break;
  }
  res[0] = lane_sum(a0);
  if (kind == kStepDots) {
    res[1] = lane_sum(a1);
    res[2] = lane_sum(a2);
    res[3] = lane_sum(a3);
    res[4] = lane_sum(a4);
  }
}

// Sums over the whole arrays (n float64 values each): blocks in parallel, combined in order.
std::vector<double> reduce(int kind, std::size_t nsum, const double* const* s, double* v, std::size_t n) {
  const long nb = static_cast<long>((n + kBlock - 1) / kBlock);
  std::vector<double> part(static_cast<std::size_t>(nb) * nsum, 0.0), total(nsum, 0.0);
  {
    nb::gil_scoped_release nogil;
#pragma omp parallel for schedule(static) if (nb >= kParallel)
    for (long k = 0; k < nb; ++k) {
      const std::size_t i0 = static_cast<std::size_t>(k) * kBlock;
      const std::size_t len = i0 + kBlock <= n ? kBlock : n - i0;
      const double* sk[5];
      for (int q = 0; q < 5; ++q) sk[q] = s[q] ? s[q] + i0 : nullptr;
      block_sums(kind, sk, v ? v + i0 : nullptr, len, part.data() + k * nsum);
    }
  }
  for (long k = 0; k < nb; ++k)
    for (std::size_t q = 0; q < nsum; ++q) total[q] += part[k * nsum + q];
  return total;
}

using cin = in<cplx, 1>;

void same_size(std::initializer_list<std::size_t> sizes, const char* what) {
  const std::size_t n0 = *sizes.begin();
  for (std::size_t n : sizes)
    if (n != n0) throw nb::value_error((std::string(what) + ": arrays of different sizes").c_str());
}

}  // namespace

double rdot(cin x, cin y) {
  same_size({x.size(), y.size()}, "rdot");
  const double* s[5] = {dbl(x.data()), dbl(y.data()), nullptr, nullptr, nullptr};
  return reduce(kRdot, 1, s, nullptr, 2 * x.size())[0];
}

double norm2(cin x) {
  const double* s[5] = {dbl(x.data()), nullptr, nullptr, nullptr, nullptr};
  return reduce(kNorm2, 1, s, nullptr, 2 * x.size())[0];
}

double rdot_diff(cin x, cin a, cin b) {
  same_size({x.size(), a.size(), b.size()}, "rdot_diff");
  const double* s[5] = {dbl(x.data()), dbl(a.data()), dbl(b.data()), nullptr, nullptr};
  return reduce(kRdotDiff, 1, s, nullptr, 2 * x.size())[0];
}

double norm2_diff(cin a, cin b) {
  same_size({a.size(), b.size()}, "norm2_diff");
  const double* s[5] = {dbl(a.data()), dbl(b.data()), nullptr, nullptr, nullptr};
  return reduce(kNorm2Diff, 1, s, nullptr, 2 * a.size())[0];
}

double rdot_diff2(cin a, cin b, cin c, cin d) {
  same_size({a.size(), b.size(), c.size(), d.size()}, "rdot_diff2");
  const double* s[5] = {dbl(a.data()), dbl(b.data()), dbl(c.data()), dbl(d.data()), nullptr};
  return reduce(kRdotDiff2, 1, s, nullptr, 2 * a.size())[0];
}

double add_twice_diff(cin a, cin b, out<cplx, 1> v) {
  same_size({a.size(), b.size(), v.size()}, "add_twice_diff");
  const double* s[5] = {dbl(a.data()), dbl(b.data()), nullptr, nullptr, nullptr};
  return reduce(kAddTwiceDiff, 1, s, dbl(v.data()), 2 * v.size())[0];
}

nb::tuple step_dots(cin f, cin f_old, cin gf, cin gf_old, cin atb) {
  same_size({f.size(), f_old.size(), gf.size(), gf_old.size(), atb.size()}, "step_dots");
  const double* s[5] = {dbl(f.data()), dbl(f_old.data()), dbl(gf.data()), dbl(gf_old.data()),
                        dbl(atb.data())};
  const std::vector<double> r = reduce(kStepDots, 5, s, nullptr, 2 * f.size());
  return nb::make_tuple(r[0], r[1], r[2], r[3], r[4]);
}

namespace {

// ---- x - a y ----------------------------------------------------------------------------------

SARCLI_CLONES
void axpy_block(const double* x, double a, const double* y, double* o, std::size_t n) {
  for (std::size_t i = 0; i < n; ++i) o[i] = x[i] - a * y[i];
}

}  // namespace

void axpy(cin x, double a, cin y, out<cplx, 1> o) {
  same_size({x.size(), y.size(), o.size()}, "axpy");
  const std::size_t n = 2 * x.size();
  const long nb = static_cast<long>((n + kBlock - 1) / kBlock);
  const double *px = dbl(x.data()), *py = dbl(y.data());
  double* po = dbl(o.data());
  nb::gil_scoped_release nogil;
#pragma omp parallel for schedule(static) if (nb >= kParallel)
  for (long k = 0; k < nb; ++k) {
    const std::size_t i0 = static_cast<std::size_t>(k) * kBlock;
    axpy_block(px + i0, a, py + i0, po + i0, i0 + kBlock <= n ? kBlock : n - i0);
  }
}

namespace {

// ---- shrinkage and multiplier update of ADMM ---------------------------------------------------
//
// g = shrink(t - σ/β, thr) grouped over the K components of a pixel, σ' = σ - β (t - g),
// w = β (t - g) - σ'; returns Σ |t| (per-pixel vector norm). σ' may be σ itself: every entry is
// read before it is written. Pixels are taken kLanes at a time (loads, then arithmetic, then
// stores), each lane with its own running sum. The outputs g, σ' and w are distinct arrays; σ'
// may be σ, whose entries of a group are all loaded before any is stored.

template <int K>
SARCLI_INLINE void shrink_group(const cplx* tf, const cplx* sig, std::size_t n, std::size_t i,
                                std::size_t m, double beta, double inv_beta, double thr,
                                cplx* __restrict g, cplx* __restrict so, cplx* __restrict w,
                                double* acc) {
  double tr[K][kLanes], ti[K][kLanes], sr[K][kLanes], si[K][kLanes], fac[kLanes];
  for (int k = 0; k < K; ++k)
    for (std::size_t l = 0; l < m; ++l) {
      tr[k][l] = tf[k * n + i + l].real();
      ti[k][l] = tf[k * n + i + l].imag();
      sr[k][l] = sig[k * n + i + l].real();
      si[k][l] = sig[k * n + i + l].imag();
    }
  for (std::size_t l = 0; l < m; ++l) {
    double t2 = 0.0, a2 = 0.0;
    for (int k = 0; k < K; ++k) {
      const double ar = tr[k][l] - sr[k][l] * inv_beta, ai = ti[k][l] - si[k][l] * inv_beta;
      t2 += tr[k][l] * tr[k][l] + ti[k][l] * ti[k][l];
      a2 += ar * ar + ai * ai;
    }
    acc[l] += std::sqrt(t2);
    const double mag = std::sqrt(a2);
    fac[l] = mag > thr ? (mag - thr) / mag : 0.0;
  }
  for (int k = 0; k < K; ++k)
    for (std::size_t l = 0; l < m; ++l) {
      const double gr = (tr[k][l] - sr[k][l] * inv_beta) * fac[l];
      const double gi = (ti[k][l] - si[k][l] * inv_beta) * fac[l];
      const double br = beta * (tr[k][l] - gr), bi = beta * (ti[k][l] - gi);
      const double nr = sr[k][l] - br, ni = si[k][l] - bi;
      const std::size_t j = k * n + i + l;
      g[j] = cplx(gr, gi);
      so[j] = cplx(nr, ni);
      if (w) w[j] = cplx(br - nr, bi - ni);
    }
}

SARCLI_CLONES
double shrink_block(int K, const cplx* tf, const cplx* sig, std::size_t n, std::size_t i0,
                    std::size_t i1, double beta, double thr, cplx* g, cplx* so, cplx* w) {
  const double inv_beta = 1.0 / beta;
  double acc[kLanes] = {};
  for (std::size_t i = i0; i < i1; i += kLanes) {
    const std::size_t m = i + kLanes <= i1 ? kLanes : i1 - i;
    if (K == 1 && m == kLanes) {  // a constant lane count: unrolled and vectorised across lanes
      shrink_group<1>(tf, sig, n, i, kLanes, beta, inv_beta, thr, g, so, w, acc);
    } else if (K == 1) {
      shrink_group<1>(tf, sig, n, i, m, beta, inv_beta, thr, g, so, w, acc);
    } else if (K == 2 && m == kLanes) {
      shrink_group<2>(tf, sig, n, i, kLanes, beta, inv_beta, thr, g, so, w, acc);
    } else if (K == 2) {
      shrink_group<2>(tf, sig, n, i, m, beta, inv_beta, thr, g, so, w, acc);
    } else {  // any K: one pixel at a time
      for (std::size_t l = 0; l < m; ++l) {
        double t2 = 0.0, a2 = 0.0;
        for (int k = 0; k < K; ++k) {
          const cplx t = tf[k * n + i + l], a = t - sig[k * n + i + l] * inv_beta;
          t2 += t.real() * t.real() + t.imag() * t.imag();
          a2 += a.real() * a.real() + a.imag() * a.imag();
        }
        acc[l] += std::sqrt(t2);
        const double mag = std::sqrt(a2), fac = mag > thr ? (mag - thr) / mag : 0.0;
        for (int k = 0; k < K; ++k) {
          const std::size_t j = k * n + i + l;
          const double tr = tf[j].real(), ti = tf[j].imag(), sr = sig[j].real(), si = sig[j].imag();
          const double gr = (tr - sr * inv_beta) * fac, gi = (ti - si * inv_beta) * fac;
          const double br = beta * (tr - gr), bi = beta * (ti - gi), nr = sr - br, ni = si - bi;
          g[j] = cplx(gr, gi);
          so[j] = cplx(nr, ni);
          if (w) w[j] = cplx(br - nr, bi - ni);
        }
      }
    }
  }
  return lane_sum(acc);
}

}  // namespace

double shrink_update(in<cplx, 2> tf, in<cplx, 2> sigma, double beta, double thr, out<cplx, 2> g,
                     out<cplx, 2> sig_out, std::optional<out<cplx, 2>> w) {
  const std::size_t K = tf.shape(0), n = tf.shape(1);
  auto same = [&](std::size_t k, std::size_t m) { return k == K && m == n; };
  if (!same(sigma.shape(0), sigma.shape(1)) || !same(g.shape(0), g.shape(1)) ||
      !same(sig_out.shape(0), sig_out.shape(1)) || (w && !same(w->shape(0), w->shape(1))))
    throw nb::value_error("shrink_update: arrays of different shapes");
  const cplx *pt = tf.data(), *ps = sigma.data();
  cplx *pg = g.data(), *po = sig_out.data(), *pw = w ? w->data() : nullptr;
  const std::size_t bs = kBlock / 2;  // pixels per block
  const long nb = static_cast<long>((n + bs - 1) / bs);  // x K components
  std::vector<double> part(static_cast<std::size_t>(nb), 0.0);
  {
    nb::gil_scoped_release nogil;
#pragma omp parallel for schedule(static) if (nb * static_cast<long>(K) >= kParallel)
    for (long k = 0; k < nb; ++k) {
      const std::size_t i0 = static_cast<std::size_t>(k) * bs, i1 = i0 + bs <= n ? i0 + bs : n;
      part[k] = shrink_block(static_cast<int>(K), pt, ps, n, i0, i1, beta, thr, pg, po, pw);
    }
  }
  double reg = 0.0;
  for (long k = 0; k < nb; ++k) reg += part[k];
  return reg;
}

namespace {

// ---- periodic first differences of a 2-D image -------------------------------------------------
//
// forward: out[0, r, c] = x[r+1, c] - x[r, c], out[1, r, c] = x[r, c+1] - x[r, c] (wrapping);
// adjoint: out[r, c] = (y[0, r-1, c] - y[0, r, c]) + (y[1, r, c-1] - y[1, r, c]).
// With a diagonal d, forward differences d x and the adjoint is multiplied by conj(d).

#define SARCLI_INLINE_LAMBDA __attribute__((always_inline))

SARCLI_INLINE void cmul(double ar, double ai, double br, double bi, double& re, double& im) {
  re = ar * br - ai * bi;
  im = ar * bi + ai * br;
}

SARCLI_CLONES
void diff_forward_row(const double* x, const double* xn, const double* d, const double* dn,
                      std::size_t nx, double* o0, double* o1) {
  if (!d) {
    for (std::size_t q = 0; q < 2 * nx; ++q) o0[q] = xn[q] - x[q];
    for (std::size_t q = 0; q + 2 < 2 * nx; ++q) o1[q] = x[q + 2] - x[q];
    o1[2 * nx - 2] = x[0] - x[2 * nx - 2];
    o1[2 * nx - 1] = x[1] - x[2 * nx - 1];
    return;
  }
  // the last column (its right neighbour wraps to column 0) after the others
  auto column = [&](std::size_t c, std::size_t cn) SARCLI_INLINE_LAMBDA {
    double vr, vi, ur, ui, wr, wi;
    cmul(d[2 * c], d[2 * c + 1], x[2 * c], x[2 * c + 1], vr, vi);
    cmul(dn[2 * c], dn[2 * c + 1], xn[2 * c], xn[2 * c + 1], ur, ui);
    cmul(d[2 * cn], d[2 * cn + 1], x[2 * cn], x[2 * cn + 1], wr, wi);
    o0[2 * c] = ur - vr;
    o0[2 * c + 1] = ui - vi;
    o1[2 * c] = wr - vr;
    o1[2 * c + 1] = wi - vi;
  };
  for (std::size_t c = 0; c + 1 < nx; ++c) column(c, c + 1);
  column(nx - 1, 0);
}

SARCLI_CLONES
void diff_adjoint_row(const double* y0p, const double* y0, const double* y1, const double* d,
                      std::size_t nx, double* o) {
  const std::size_t L = 2 * nx;
  double sr = (y0p[0] - y0[0]) + (y1[L - 2] - y1[0]);
  double si = (y0p[1] - y0[1]) + (y1[L - 1] - y1[1]);
  if (!d) {
    o[0] = sr;
    o[1] = si;
    for (std::size_t q = 2; q < L; ++q) o[q] = (y0p[q] - y0[q]) + (y1[q - 2] - y1[q]);
    return;
  }
  for (std::size_t c = 0; c < nx; ++c) {
    if (c > 0) {
      sr = (y0p[2 * c] - y0[2 * c]) + (y1[2 * c - 2] - y1[2 * c]);
      si = (y0p[2 * c + 1] - y0[2 * c + 1]) + (y1[2 * c - 1] - y1[2 * c + 1]);
    }
    cmul(d[2 * c], -d[2 * c + 1], sr, si, o[2 * c], o[2 * c + 1]);
  }
}

}  // namespace

void diff2d_forward(in<cplx, 2> x, std::optional<in<cplx, 2>> d, out<cplx, 3> o) {
  const std::size_t ny = x.shape(0), nx = x.shape(1);
  if (o.shape(0) != 2 || o.shape(1) != ny || o.shape(2) != nx || (d && (d->shape(0) != ny || d->shape(1) != nx)))
    throw nb::value_error("diff2d_forward: inconsistent shapes");
  if (ny == 0 || nx == 0) return;
  const double* px = dbl(x.data());
  const double* pd = d ? dbl(d->data()) : nullptr;
  double* po = dbl(o.data());
  const long rows = static_cast<long>(ny);
  const std::size_t L = 2 * nx;
  nb::gil_scoped_release nogil;
#pragma omp parallel for schedule(static) if (2 * ny * nx >= kParallel * kBlock)
  for (long r = 0; r < rows; ++r) {
    const std::size_t rn = static_cast<std::size_t>(r) + 1 < ny ? r + 1 : 0;
    diff_forward_row(px + r * L, px + rn * L, pd ? pd + r * L : nullptr, pd ? pd + rn * L : nullptr,
                     nx, po + r * L, po + (ny + r) * L);
  }
}

void diff2d_adjoint(in<cplx, 3> y, std::optional<in<cplx, 2>> d, out<cplx, 2> o) {
  const std::size_t ny = y.shape(1), nx = y.shape(2);
  if (y.shape(0) != 2 || o.shape(0) != ny || o.shape(1) != nx || (d && (d->shape(0) != ny || d->shape(1) != nx)))
    throw nb::value_error("diff2d_adjoint: inconsistent shapes");
  if (ny == 0 || nx == 0) return;
  const double* py = dbl(y.data());
  const double* pd = d ? dbl(d->data()) : nullptr;
  double* po = dbl(o.data());
  const long rows = static_cast<long>(ny);
  const std::size_t L = 2 * nx;
  nb::gil_scoped_release nogil;
#pragma omp parallel for schedule(static) if (2 * ny * nx >= kParallel * kBlock)
  for (long r = 0; r < rows; ++r) {
    const std::size_t rp = r > 0 ? r - 1 : ny - 1;
    diff_adjoint_row(py + rp * L, py + r * L, py + (ny + r) * L, pd ? pd + r * L : nullptr, nx,
                     po + r * L);
  }
}

}  // namespace sarcli
