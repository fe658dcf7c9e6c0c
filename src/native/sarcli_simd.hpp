// Shared helpers of sarcli's kernels: run-time SIMD dispatch and array views.
//
// SARCLI_CLONES marks a hot function to be compiled three times (AVX-512, AVX2+FMA, baseline
// x86-64) and picked by the CPU at load time (GCC/Clang target_clones, an ifunc). OpenMP outlines
// a parallel region into a function of its own that target_clones does not reach, so put the
// attribute on the per-row / per-pulse worker that the parallel loop calls, and mark the small
// helpers it calls SARCLI_INLINE so they are compiled into each clone.
#pragma once

#include <cstddef>
#include <cstdint>

#include <nanobind/nanobind.h>
#include <nanobind/ndarray.h>

#include "numerics/inline.hpp"

#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__)) && !defined(SARCLI_NO_CLONES)
#define SARCLI_CLONES __attribute__((target_clones("arch=x86-64-v4", "arch=x86-64-v3", "default")))
#else
#define SARCLI_CLONES
#endif

namespace sarcli {

namespace nb = nanobind;

// C-contiguous CPU arrays of a fixed rank, read-only or writable.
template <typename T, std::size_t N>
using in = nb::ndarray<const T, nb::ndim<N>, nb::c_contig, nb::device::cpu>;
template <typename T, std::size_t N>
using out = nb::ndarray<T, nb::ndim<N>, nb::c_contig, nb::device::cpu>;

}  // namespace sarcli
