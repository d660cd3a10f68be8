// orifice_flow: the flow through an open reed valve loses kinetic energy like
// an orifice, dp = rho q|q| / (2 Cd^2 A^2) on top of the viscous R(x) q
// (docs/stokes.md: +41 % on R at port Reynolds number 91). The bounds reach
// past the physical Cd <= 1 to 100, where the loss is 1e-4 of Cd = 1's and
// vanishes into R(x): a wrong fit can fall back to no effect (at 10 a loaded
// run still moved 1.5 % of its swing; tests/test_diagnosis.cpp,
// EveryEffectsRangeReachesNoEffect).
#include "diagnosis/effect.h"

namespace rectify::diagnosis
{
  std::shared_ptr<const Effect> make_orifice_flow()
  {
    return std::make_shared<Effect>(
      "orifice_flow",
      "nonlinear (inertial) loss through each open valve, rho q|q| / (2 Cd^2 A^2) with A the "
      "curtain area (port perimeter x tip opening), in series with the viscous R(x)",
      "errors where the flow through the valves peaks (mid-stroke), with odd harmonics; the "
      "reed opens wider, the stored pressure falls, more at high frequency (high flow)",
      // 15 grid points: 0.17 decade apart, as 9 were over the former 0.3..10
      std::vector<EffectParameter>{{"valves", "orifice_discharge_coefficient", 0.3, 100.0, true,
                                    "discharge coefficient of the valve's curtain area", 15}},
      [](std::span<const double> v, system::SystemParameters &p) {
        p.valves.orifice_discharge_coefficient = v[0];
      });
  }
} // namespace rectify::diagnosis
