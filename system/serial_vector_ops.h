// SUNDIALS's serial vector operations compiled with this project's
// optimisation. Debian's libsundials-cvode 6.4.1 is built without any: its
// loops load and store every operand through the stack, and they took 47 % of
// a loaded diagnosis's time (docs/benchmarks.md, 2026-11-30). The
// replacements compute what the library's do, operation for operation: the
// same special cases of a x + b y (each rounds differently), the same
// summation order in the norms (element-wise loops may be vectorised, which
// changes no result; a sum is not reordered without -ffast-math, and the file
// is compiled with -ffp-contract=off, so no multiply-add is fused even on a
// target that has FMA: system/CMakeLists.txt). So an integration gives the
// same numbers to the last bit: tests/test_system.cpp compares each
// operation against the library's own, tests/test_effects.cpp whole runs.
#pragma once

#include <nvector/nvector_serial.h>

namespace rectify::system
{
  /// Replace v's arithmetic operations (a x + b y, constants, scaling,
  /// element-wise products, quotients, absolute values, inverses, the norms
  /// and reductions CVODE uses) by the optimised ones. Clones made from v
  /// afterwards (CVODE's own vectors) inherit them. Fused and vector-array
  /// operations stay disabled, as the library leaves them: CVODE then falls
  /// back to the single operations.
  void use_optimised_serial_ops(N_Vector v);
} // namespace rectify::system
