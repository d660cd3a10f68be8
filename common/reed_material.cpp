#include "common/reed_material.h"

namespace rectify
{
  ReedMaterial ReedMaterial::from_case(const CaseFile &f)
  {
    ReedMaterial      m;
    const std::string t = "reed_material";
    m.youngs_modulus_Pa = f.real(t, "youngs_modulus_Pa", m.youngs_modulus_Pa, Bounds::positive());
    m.poisson_ratio     = f.real(t, "poisson_ratio", m.poisson_ratio, Bounds::open(-1.0, 0.5));
    m.density_kg_per_m3 = f.real(t, "density_kg_per_m3", m.density_kg_per_m3, Bounds::positive());
    return m;
  }
} // namespace rectify
