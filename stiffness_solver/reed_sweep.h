// The reed over a range of thicknesses (the thickness what-if): one
// stiffness-and-modes solve per thickness, checkpointed (resumable), as a
// reed map (maps/reed_map.h).
#pragma once

#include <filesystem>
#include <vector>

#include "maps/reed_map.h"
#include "stiffness_solver/parameters.h"

namespace rectify::stiffness
{
  struct ReedSweepResult
  {
    maps::ReedMap map;
    double        k_loglog_slope = 0; ///< d log k / d log t by least squares (3 for a thin plate)
    std::size_t   n_resumed      = 0;
  };

  /// Solves the reed of `base` at each thickness; finished thicknesses go to
  /// `checkpoint_dir`/map-partial.csv at once, and a run with the same
  /// settings resumes from them. InputError for a thickness that is not a thin plate.
  ReedSweepResult reed_thickness_sweep(const StiffnessParameters &base, const std::vector<double> &thicknesses,
                                       const std::filesystem::path &checkpoint_dir);
} // namespace rectify::stiffness
