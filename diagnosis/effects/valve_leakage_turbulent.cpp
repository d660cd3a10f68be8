// valve_leakage_turbulent: oil leaks past both reed valves through a short,
// wide path (a nick in the seat, a lifted corner): an orifice whose drop
// grows with the flow squared, rho q|q| / (2 A^2), where valve_leakage's
// long, narrow path has a drop proportional to the flow. Two forms of one
// physics (issue 17): which one a record follows is itself a finding. The
// turbulent leak passes relatively more at small drops, so the outlet
// pressure recoils on after the laminar form would have levelled off.
#include "diagnosis/effect.h"

namespace rectify::diagnosis
{
  std::shared_ptr<const Effect> make_valve_leakage_turbulent()
  {
    return std::make_shared<Effect>(
      "valve_leakage_turbulent",
      "leakage past each reed valve through an orifice (drop ~ flow squared) in parallel with the "
      "valve, open or shut",
      "outlet pressure recoils after each peak while the outlet valve is shut, fast at first and "
      "on at small drops; the stored pressure levels off lower; worst at low frequency",
      std::vector<EffectParameter>{{"valves", "leak_area_m2", 1e-11, 1e-5, true,
                                    "effective flow area (discharge coefficient x area) of the leak "
                                    "orifice past each valve"}},
      [](std::span<const double> v, system::SystemParameters &p) { p.valves.leak_area_m2 = v[0]; });
  }
} // namespace rectify::diagnosis
