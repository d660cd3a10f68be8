#include "common/reed_material.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace rectify
{
  double ReedMaterial::goodman_factor(double mean_Pa, double amplitude_Pa) const
  {
    // A compressive mean does not help in Goodman's line (taken as 0).
    const double d = std::abs(amplitude_Pa) / endurance_limit_Pa + std::max(mean_Pa, 0.0) / ultimate_strength_Pa;
    return d > 0 ? 1.0 / d : std::numeric_limits<double>::infinity();
  }

  const RealKeys<ReedMaterial> &material_keys()
  {
    using T = ReedMaterial;
    static const RealKeys<T> keys{
      {"youngs_modulus_Pa", &T::youngs_modulus_Pa, Bounds::positive(), false},
      {"poisson_ratio", &T::poisson_ratio, Bounds::open(-1.0, 0.5), false},
      {"density_kg_per_m3", &T::density_kg_per_m3, Bounds::positive(), false},
      {"ultimate_strength_Pa", &T::ultimate_strength_Pa, Bounds::positive(), false},
      {"endurance_limit_Pa", &T::endurance_limit_Pa, Bounds::positive(), false}};
    return keys;
  }

  ReedMaterial ReedMaterial::from_case(const CaseFile &f)
  {
    ReedMaterial      m;
    const std::string t = "reed_material";
    read_reals(f, t, material_keys(), m);
    if (m.endurance_limit_Pa > m.ultimate_strength_Pa)
      throw InputError(f.where(t, "endurance_limit_Pa") + " = " + format_number(m.endurance_limit_Pa) +
                       ": above the ultimate strength (ultimate_strength_Pa = " +
                       format_number(m.ultimate_strength_Pa) + "); a material's endurance limit lies below it");
    return m;
  }
} // namespace rectify
