// The reference case's system parameters and R(x) map, for the model tests.
#pragma once

#include "common/case_file.h"
#include "maps/resistance_map.h"
#include "system/parameters.h"

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
} // namespace rectify::test_support
