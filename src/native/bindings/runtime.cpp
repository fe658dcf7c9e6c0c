// The Python module sarcli._native._runtime: bindings of runtime.hpp.
#include <nanobind/nanobind.h>

#include "runtime.hpp"

NB_MODULE(_runtime, m) {
  using namespace nanobind::literals;
  m.doc() = "OpenMP thread count of sarcli's kernels.";
  m.def("set_num_threads", &sarcli::set_num_threads, "n"_a,
        "Threads of the kernels that the calling thread starts from now on.");
  m.def("get_max_threads", &sarcli::get_max_threads, "Threads a kernel started by the calling thread would use.");
  m.def("simd_level", &sarcli::simd_level, "The SIMD clone the kernels run on this CPU.");
}
