// Separable spreading and interpolation with precomputed weights, in single precision: the
// pixel <-> uniform-grid steps of the warped operator's Gram (sarcli.linops.warped).
//
// Each point n has a base node (i0[n], j0[n]) and W weights along each axis, wy[n, a] and
// wx[n, b] (a tensor-product kernel, evaluated once in Python when the operator is built):
//
//   spread:  grid[i0 + a, j0 + b] += phase[n] f[n] wy[n, a] wx[n, b]
//   interp:  out[n] = conj(phase[n]) Σ_ab grid[i0 + a, j0 + b] wy[n, a] wx[n, b]
//
// interp is exactly the adjoint of spread (same weights, the conjugate phase). Every tap must lie
// inside the grid (checked). spread runs each thread over a contiguous share of the points into
// a grid of its own (the first thread's is the output, the others' the caller's scratch), then
// adds them row by row in thread order: the result depends on the thread count only through the
// order of float32 additions.
#include <cmath>
#include <complex>
#include <algorithm>
#include <cstring>
#include <string>

#include <omp.h>

#include "spread.hpp"
#include "sarcli_simd.hpp"

namespace sarcli {
namespace {

using cf = std::complex<float>;
constexpr int kMaxTaps = 16;

template <int W>
SARCLI_INLINE void spread_point(float vr, float vi, const float* ay, const float* ax, float* g,
                                std::size_t row) {
#pragma GCC unroll 16
  for (int a = 0; a < W; ++a) {
    const float tr = vr * ay[a], ti = vi * ay[a];
    float* gr = g + 2 * row * a;
#pragma GCC unroll 16
    for (int b = 0; b < W; ++b) {
      gr[2 * b] += tr * ax[b];
      gr[2 * b + 1] += ti * ax[b];
    }
  }
}

template <int W>
SARCLI_INLINE void interp_point(const float* ay, const float* ax, const float* g, std::size_t row,
                                float& sr, float& si) {
  sr = 0.f;
  si = 0.f;
#pragma GCC unroll 16
  for (int a = 0; a < W; ++a) {
    const float* gr = g + 2 * row * a;
    float rr = 0.f, ri = 0.f;
#pragma GCC unroll 16
    for (int b = 0; b < W; ++b) {
      rr += gr[2 * b] * ax[b];
      ri += gr[2 * b + 1] * ax[b];
    }
    sr += rr * ay[a];
    si += ri * ay[a];
  }
}

struct Points {
  const int* i0;
  const int* j0;
  const float* wy;
  const float* wx;
  const cf* phase;
};

template <int W>
SARCLI_CLONES void spread_range(const Points& p, const cf* f, long lo, long hi, float* grid, std::size_t n1) {
  for (long n = lo; n < hi; ++n) {
    const cf v = p.phase[n] * f[n];
    spread_point<W>(v.real(), v.imag(), p.wy + n * W, p.wx + n * W,
                    grid + 2 * (static_cast<std::size_t>(p.i0[n]) * n1 + p.j0[n]), n1);
  }
}

template <int W>
SARCLI_CLONES void interp_range(const Points& p, const float* grid, long lo, long hi, std::size_t n1, cf* out) {
  for (long n = lo; n < hi; ++n) {
    float sr, si;
    interp_point<W>(p.wy + n * W, p.wx + n * W, grid + 2 * (static_cast<std::size_t>(p.i0[n]) * n1 + p.j0[n]),
                    n1, sr, si);
    out[n] = std::conj(p.phase[n]) * cf(sr, si);
  }
}

SARCLI_CLONES void add_rows(float* dst, const float* src, std::size_t n) {
  for (std::size_t q = 0; q < n; ++q) dst[q] += src[q];
}

template <int W>
void spread_w(const Points& p, const cf* f, long n, cf* grid, cf* scratch, int nscratch, std::size_t n0,
              std::size_t n1) {
  const int threads = std::max(1, std::min(omp_get_max_threads(), nscratch + 1));
  const std::size_t cells = n0 * n1;
#pragma omp parallel num_threads(threads)
  {
    const int t = omp_get_thread_num(), nt = omp_get_num_threads();
    cf* own = t == 0 ? grid : scratch + static_cast<std::size_t>(t - 1) * cells;
    std::memset(static_cast<void*>(own), 0, cells * sizeof(cf));
    spread_range<W>(p, f, n * t / nt, n * (t + 1) / nt, reinterpret_cast<float*>(own), n1);
#pragma omp barrier
    if (nt > 1) {
#pragma omp for schedule(static)
      for (long r = 0; r < static_cast<long>(n0); ++r)
        for (int s = 1; s < nt; ++s)
          add_rows(reinterpret_cast<float*>(grid + r * n1),
                   reinterpret_cast<const float*>(scratch + (s - 1) * cells + r * n1), 2 * n1);
    }
  }
}

template <int W>
void interp_w(const Points& p, const cf* grid, long n, std::size_t n1, cf* out) {
#pragma omp parallel
  {
    const int t = omp_get_thread_num(), nt = omp_get_num_threads();
    interp_range<W>(p, reinterpret_cast<const float*>(grid), n * t / nt, n * (t + 1) / nt, n1, out);
  }
}

template <template <int> class F, typename... A>
void by_taps(int w, A&&... args) {
  switch (w) {
#define SARCLI_TAPS(k) \
  case k:              \
    return F<k>::run(args...);
    SARCLI_TAPS(2) SARCLI_TAPS(3) SARCLI_TAPS(4) SARCLI_TAPS(5) SARCLI_TAPS(6) SARCLI_TAPS(7)
    SARCLI_TAPS(8) SARCLI_TAPS(9) SARCLI_TAPS(10) SARCLI_TAPS(11) SARCLI_TAPS(12) SARCLI_TAPS(13)
    SARCLI_TAPS(14) SARCLI_TAPS(15) SARCLI_TAPS(16)
#undef SARCLI_TAPS
    default:
      throw nb::value_error("spread: the kernel must have 2 to 16 taps");
  }
}

template <int W>
struct Spread {
  template <typename... A>
  static void run(A&&... a) { spread_w<W>(a...); }
};
template <int W>
struct Interp {
  template <typename... A>
  static void run(A&&... a) { interp_w<W>(a...); }
};

// shapes agree and every tap lies inside the (n0, n1) grid
Points check(in<int, 1> i0, in<int, 1> j0, in<float, 2> wy, in<float, 2> wx, in<cf, 1> phase,
             std::size_t n0, std::size_t n1, const char* who) {
  const std::size_t n = i0.shape(0), w = wy.shape(1);
  if (j0.shape(0) != n || wy.shape(0) != n || wx.shape(0) != n || wx.shape(1) != w || phase.shape(0) != n)
    throw nb::value_error((std::string(who) + ": inconsistent point arrays").c_str());
  if (w < 2 || w > kMaxTaps) throw nb::value_error((std::string(who) + ": 2 to 16 taps").c_str());
  const int* pi = i0.data();
  const int* pj = j0.data();
  for (std::size_t q = 0; q < n; ++q)
    if (pi[q] < 0 || pj[q] < 0 || static_cast<std::size_t>(pi[q]) + w > n0 || static_cast<std::size_t>(pj[q]) + w > n1)
      throw nb::value_error((std::string(who) + ": a point's taps leave the grid").c_str());
  return Points{pi, pj, wy.data(), wx.data(), phase.data()};
}

}  // namespace

void spread(in<int, 1> i0, in<int, 1> j0, in<float, 2> wy, in<float, 2> wx, in<cf, 1> phase, in<cf, 1> f,
            out<cf, 2> grid, out<cf, 3> scratch) {
  const std::size_t n0 = grid.shape(0), n1 = grid.shape(1);
  const Points p = check(i0, j0, wy, wx, phase, n0, n1, "spread");
  if (f.shape(0) != i0.shape(0)) throw nb::value_error("spread: f and the points differ in length");
  if (scratch.shape(0) > 0 && (scratch.shape(1) != n0 || scratch.shape(2) != n1))
    throw nb::value_error("spread: scratch grids must have the grid's shape");
  const int w = static_cast<int>(wy.shape(1));
  nb::gil_scoped_release nogil;
  by_taps<Spread>(w, p, f.data(), static_cast<long>(f.shape(0)), grid.data(), scratch.data(),
                  static_cast<int>(scratch.shape(0)), n0, n1);
}

void interp(in<int, 1> i0, in<int, 1> j0, in<float, 2> wy, in<float, 2> wx, in<cf, 1> phase, in<cf, 2> grid,
            out<cf, 1> o) {
  const std::size_t n0 = grid.shape(0), n1 = grid.shape(1);
  const Points p = check(i0, j0, wy, wx, phase, n0, n1, "interp");
  if (o.shape(0) != i0.shape(0)) throw nb::value_error("interp: out and the points differ in length");
  const int w = static_cast<int>(wy.shape(1));
  nb::gil_scoped_release nogil;
  by_taps<Interp>(w, p, grid.data(), static_cast<long>(o.shape(0)), n1, o.data());
}

namespace {

SARCLI_CLONES void weights_range(const double* x, long lo, long hi, int taps, const double* v, long nv, double z0,
                                 double step, int* first, float* w) {
  for (long n = lo; n < hi; ++n) {
    const double f = std::ceil(x[n] - 0.5 * taps);
    first[n] = static_cast<int>(f);
    for (int j = 0; j < taps; ++j) {
      const double pos = (f + j - x[n] - z0) / step;
      long i = static_cast<long>(pos);
      i = i < 0 ? 0 : (i > nv - 2 ? nv - 2 : i);
      const double t = pos - static_cast<double>(i);
      w[n * taps + j] = static_cast<float>((1.0 - t) * v[i] + t * v[i + 1]);
    }
  }
}

}  // namespace

// first[n] = ceil(x[n] - taps/2) and w[n, j] = the table's value at node - x = first + j - x,
// interpolated linearly in the uniform table v of z = z0 + k step
void kernel_weights(in<double, 1> x, int taps, in<double, 1> v, double z0, double step, out<int, 1> first,
                    out<float, 2> w) {
  const long n = static_cast<long>(x.shape(0));
  if (first.shape(0) != x.shape(0) || w.shape(0) != x.shape(0) || w.shape(1) != static_cast<std::size_t>(taps) ||
      taps < 2 || taps > kMaxTaps || v.shape(0) < 2 || !(step > 0))
    throw nb::value_error("kernel_weights: inconsistent arguments");
  const double* px = x.data();
  const double* pv = v.data();
  int* pf = first.data();
  float* pw = w.data();
  const long nv = static_cast<long>(v.shape(0));
  nb::gil_scoped_release nogil;
#pragma omp parallel
  {
    const int t = omp_get_thread_num(), nt = omp_get_num_threads();
    weights_range(px, n * t / nt, n * (t + 1) / nt, taps, pv, nv, z0, step, pf, pw);
  }
}

}  // namespace sarcli
