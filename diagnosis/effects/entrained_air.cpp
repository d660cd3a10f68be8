// entrained_air: free air in the oil, compressed with the local pressure, so
// the oil is softest at low pressure (thesis eqs. 3.22-3.26 evaluated at the
// local pressure instead of the bias).
#include "diagnosis/effect.h"

namespace rectify::diagnosis
{
  std::shared_ptr<const Effect> make_entrained_air()
  {
    return std::make_shared<Effect>(
      "entrained_air",
      "free air in the oil (gas volume fraction at the bias pressure), compressed polytropically "
      "with the local pressure: the chamber, high and low sides soften at low pressure",
      "chamber pressure swings less and lags during refill (low pressure, soft oil); the stored "
      "pressure builds up more slowly; errors grow at higher frequency",
      // 14 grid points: 0.38 decade apart, as 9 were over the former 1e-5..2e-2
      std::vector<EffectParameter>{{"fluid", "free_air_fraction", 1e-7, 2e-2, true,
                                    "free-air volume fraction at the bias pressure", 14}},
      [](std::span<const double> v, system::SystemParameters &p) {
        p.fluid.free_air_fraction = v[0];
      });
  }
} // namespace rectify::diagnosis
