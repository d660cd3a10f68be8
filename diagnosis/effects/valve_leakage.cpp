// valve_leakage: oil leaks past both reed valves when they are shut (a worn
// or dirty seat), through a path in parallel with each valve.
#include "diagnosis/effect.h"

namespace rectify::diagnosis
{
  std::shared_ptr<const Effect> make_valve_leakage()
  {
    return std::make_shared<Effect>(
      "valve_leakage",
      "leakage past each reed valve through a path of fixed resistance in parallel with the "
      "valve, open or shut",
      "outlet pressure recoils (falls back toward the chamber pressure) after each peak while "
      "the outlet valve is shut; the stored pressure levels off lower; worst at low frequency",
      std::vector<EffectParameter>{{"valves", "leak_resistance_Pa_s_per_m3", 1e10, 1e16, true,
                                    "resistance of the leak path past each valve"}},
      [](std::span<const double> v, system::SystemParameters &p) {
        p.valves.leak_resistance_Pa_s_per_m3 = v[0];
      });
  }
} // namespace rectify::diagnosis
