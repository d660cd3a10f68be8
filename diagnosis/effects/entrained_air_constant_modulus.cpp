// entrained_air_constant_modulus: free air in the oil with a fixed bulk
// modulus (gamma p_bias), the form of the thesis's eq. 3.26 at the bias
// pressure: a constant extra compliance, unlike entrained_air's gas law,
// which softens the oil at low pressure. Two forms of one physics: which one
// a record follows is itself a finding (issue 17).
#include "diagnosis/effect.h"

namespace rectify::diagnosis
{
  std::shared_ptr<const Effect> make_entrained_air_constant_modulus()
  {
    return std::make_shared<Effect>(
      "entrained_air_constant_modulus",
      "free air in the oil (gas volume fraction at the bias pressure) with a constant bulk modulus "
      "gamma p_bias: the chamber, high and low sides uniformly softer",
      "chamber pressure swings less at every pressure; the stored pressure builds up more slowly",
      // 14 grid points: 0.38 decade apart, as 9 were over the former 1e-5..2e-2
      std::vector<EffectParameter>{{"fluid", "free_air_fraction", 1e-7, 2e-2, true,
                                    "free-air volume fraction at the bias pressure", 14}},
      [](std::span<const double> v, system::SystemParameters &p) {
        p.fluid.free_air_fraction = v[0];
        p.fluid.free_air_law      = "constant-modulus";
      },
      std::vector<Effect::FixedKey>{{"fluid", "free_air_law", "\"constant-modulus\""}});
  }
} // namespace rectify::diagnosis
