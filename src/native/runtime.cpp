// The OpenMP runtime that every kernel module shares (libgomp is one per process).
#include "runtime.hpp"

#include <omp.h>

namespace sarcli {

// Threads of the kernels that the calling thread starts from now on (at least one).
void set_num_threads(int n) { omp_set_num_threads(n < 1 ? 1 : n); }

// Threads a kernel started by the calling thread would use.
int get_max_threads() { return omp_get_max_threads(); }

// The SIMD clone the kernels run on this CPU: avx512, avx2 or baseline.
const char* simd_level() {
#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__))
  __builtin_cpu_init();
  if (__builtin_cpu_supports("x86-64-v4")) return "avx512";
  if (__builtin_cpu_supports("x86-64-v3")) return "avx2";
#endif
  return "baseline";
}

}  // namespace sarcli
