// The interpolators by the code the Python side passes as `kind` (sarcli.core.sampling.INTERPOLATORS
// names the same codes; the tests compare them), and their taps.
#pragma once

namespace sarcli {
namespace interp {

enum Kind { kLinear = 0, kKeysCubic = 1, kLanczos3 = 2, kPoly6 = 3 };
// taps of each kind; kPoly6: the 6-tap polynomial weights of a table (ffbp's designed kernels)
constexpr int kTaps[4] = {2, 4, 6, 6};
// the names sarcli.core.sampling.INTERPOLATORS gives them
constexpr const char* kNames[4] = {"linear", "cubic", "lanczos", "optimal"};

}  // namespace interp
}  // namespace sarcli
