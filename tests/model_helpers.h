// The reference case's system parameters and R(x) map, for the model tests.
#pragma once

#include "common/case_file.h"
#include "maps/resistance_map.h"
#include "system/parameters.h"
#include "system/simulation.h"

namespace rectify::test_support
{
  inline system::SystemParameters reference()
  {
    return system::SystemParameters::from_case(CaseFile::load(reference_case_path()));
  }

  inline maps::ResistanceMap reference_map(const system::SystemParameters &p)
  {
    return maps::ResistanceMap::read(p.valves.resistance_map,
                                     maps::parse_interpolation(p.valves.interpolation));
  }
  /// A fixed-length run of `cycles` cycles with the case's tolerances.
  inline system::RunOptions run_options(const system::SystemParameters &p, std::size_t cycles)
  {
    system::RunOptions o;
    o.n_cycles                  = cycles;
    o.relative_tolerance        = p.solver.relative_tolerance;
    o.absolute_tolerance_factor = p.solver.absolute_tolerance_factor;
    return o;
  }
} // namespace rectify::test_support
