// reed_second_mode: the reed's second bending mode, excited by each opening.
#include "diagnosis/effect.h"

namespace rectify::diagnosis
{
  std::shared_ptr<const Effect> make_reed_second_mode()
  {
    return std::make_shared<Effect>(
      "reed_second_mode",
      "a second bending mode of each reed (uniform cantilever: about 6.27 x the first "
      "frequency), with the first mode's modal mass and damping ratio; the tip opening is the "
      "sum of both, and the seat holds the tip, not the reed",
      "high-frequency ringing of the valve opening (and the outlet pressure) at each opening, "
      "at the second mode's frequency, above the harmonics the first mode explains",
      // 17 start points: the residual has narrow basins over the frequency
      // (the mode's ringing after each opening), which 9 points can miss
      std::vector<EffectParameter>{{"reed", "second_mode_frequency_Hz", 1500.0, 9000.0, true,
                                    "second bending mode's natural frequency", 17}},
      [](std::span<const double> v, system::SystemParameters &p) {
        p.reed.second_mode_frequency_Hz = v[0];
      });
  }
} // namespace rectify::diagnosis
