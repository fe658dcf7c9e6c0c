// The OpenMP runtime that every kernel module shares (runtime.cpp): the entry points that
// bindings/runtime.cpp binds.
#pragma once

namespace sarcli {

void set_num_threads(int n);
int get_max_threads();
const char* simd_level();

}  // namespace sarcli
