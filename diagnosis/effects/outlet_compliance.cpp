// outlet_compliance: a soft element on the outlet side (a seal, a hose) that
// stores oil as the outlet pressure rises.
#include "diagnosis/effect.h"

namespace rectify::diagnosis
{
  std::shared_ptr<const Effect> make_outlet_compliance()
  {
    return std::make_shared<Effect>(
      "outlet_compliance",
      "extra compliance on the high (outlet) side, a soft seal or hose, in parallel with the "
      "oil column's",
      "outlet pressure rises more slowly from cycle to cycle and ripples less; the chamber is "
      "unaffected while the outlet valve is shut",
      // 12 grid points: 0.8 decade apart, as 9 were over the former 1e-17..3e-10
      std::vector<EffectParameter>{{"cylinder", "seal_compliance_m3_per_Pa", 1e-19, 3e-10, true,
                                    "extra high-side compliance", 12}},
      [](std::span<const double> v, system::SystemParameters &p) {
        p.cylinder.seal_compliance_m3_per_Pa = v[0];
      },
      std::vector<Effect::FixedKey>{},
      // The seal sits in parallel with the high side's oil column, whose
      // length is one of the baseline's uncertain parameters: a record
      // tells their sum, not always the split.
      Effect::Combination{"high_side_compliance_m3_per_Pa",
                          "the high side's compliance: the oil column's (cylinder.wetted_length_m) and the seal's",
                          [](const system::SystemParameters &p) {
                            return p.cylinder.piston_area_m2 * p.cylinder.high_side_fraction *
                                     p.cylinder.wetted_length_m / p.fluid.effective_bulk_modulus_Pa() +
                                   p.cylinder.seal_compliance_m3_per_Pa;
                          }});
  }
} // namespace rectify::diagnosis
