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

  ReedMaterial ReedMaterial::from_case(const CaseFile &f)
  {
    ReedMaterial      m;
    const std::string t = "reed_material";
    m.youngs_modulus_Pa = f.real(t, "youngs_modulus_Pa", m.youngs_modulus_Pa, Bounds::positive());
    m.poisson_ratio     = f.real(t, "poisson_ratio", m.poisson_ratio, Bounds::open(-1.0, 0.5));
    m.density_kg_per_m3 = f.real(t, "density_kg_per_m3", m.density_kg_per_m3, Bounds::positive());
    m.ultimate_strength_Pa = f.real(t, "ultimate_strength_Pa", m.ultimate_strength_Pa, Bounds::positive());
    m.endurance_limit_Pa   = f.real(t, "endurance_limit_Pa", m.endurance_limit_Pa, Bounds::positive());
    if (m.endurance_limit_Pa > m.ultimate_strength_Pa)
      throw InputError(f.where(t, "endurance_limit_Pa") + " = " + format_number(m.endurance_limit_Pa) +
                       ": above the ultimate strength (ultimate_strength_Pa = " +
                       format_number(m.ultimate_strength_Pa) + "); a material's endurance limit lies below it");
    return m;
  }
} // namespace rectify
