// The OpenMP runtime that every kernel module shares (libgomp is one per process).
#include <omp.h>

#include "sarcli_simd.hpp"

NB_MODULE(_runtime, m) {
  using namespace nanobind::literals;
  m.doc() = "OpenMP thread count of sarcli's kernels.";
  m.def("set_num_threads", [](int n) { omp_set_num_threads(n < 1 ? 1 : n); }, "n"_a,
        "Threads of the kernels that the calling thread starts from now on.");
  m.def("get_max_threads", []() { return omp_get_max_threads(); },
        "Threads a kernel started by the calling thread would use.");
  m.def("simd_level", []() {
#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__))
    __builtin_cpu_init();
    if (__builtin_cpu_supports("x86-64-v4")) return "avx512";
    if (__builtin_cpu_supports("x86-64-v3")) return "avx2";
#endif
    return "baseline";
  }, "The SIMD clone the kernels run on this CPU.");
}
