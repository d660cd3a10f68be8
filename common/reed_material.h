// The reed's material: case table [reed_material]. Shared by the stiffness
// solver (which uses it) and the map sets (which record it, so that a map
// set made for another material is refused).
#pragma once

#include "common/case_file.h"

namespace rectify
{
  struct ReedMaterial
  {
    double youngs_modulus_Pa = 200e9;  ///< 304 stainless steel (thesis Table 3.1)
    double poisson_ratio     = 0.29;   ///< not in the thesis; typical of 304
    double density_kg_per_m3 = 8000.0; ///< thesis Table 3.1
    static ReedMaterial from_case(const CaseFile &file);
  };
} // namespace rectify
