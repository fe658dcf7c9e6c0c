// SARCLI_INLINE: a helper compiled into each SIMD copy of the worker that calls it (sarcli_simd.hpp).
#pragma once

#ifndef SARCLI_INLINE
#define SARCLI_INLINE inline __attribute__((always_inline))
#endif
