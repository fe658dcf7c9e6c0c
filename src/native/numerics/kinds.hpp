// The interpolators by the code the Python side passes as `kind` (sarcli.core.sampling.INTERPOLATORS
// names the same codes; the tests compare them), and their taps.
#pragma once

namespace sarcli {
namespace interp {

enum Kind { kLinear = 0, kKeysCubic = 1, kLanczos3 = 2, kPoly6 = 3, kLagrange3 = 4 };
constexpr int kKinds = 5;
// taps of each kind; kPoly6: the 6-tap polynomial weights of a table (ffbp's designed kernels);
// kLagrange3: the cubic Lagrange polynomial through 4 samples
constexpr int kTaps[kKinds] = {2, 4, 6, 6, 4};
// the names sarcli.core.sampling.INTERPOLATORS gives them
constexpr const char* kNames[kKinds] = {"linear", "cubic", "lanczos", "optimal", "lagrange"};
// the kinds that read range profiles (backprojection's): all but kPoly6, which ffbp designs per level
constexpr bool profile_kind(int kind) { return kind >= kLinear && kind < kKinds && kind != kPoly6; }

}  // namespace interp
}  // namespace sarcli
