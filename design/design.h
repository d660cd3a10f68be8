// `rectify design`: one valve design, every map. For the valve of a case
// file: the reed's stiffness solve (k_r, modal and added mass, modes, FE
// deflected shape), then the fluid mesh on that FE shape and Stokes flow
// over tip openings chosen by accuracy (stokes_solver/resistance_sweep.h),
// written as one map set (maps/map_set.h) with its manifest, tables, plots
// and a report. Resumable: the reed and every solved opening are kept in
// DIR/partial/ until the map set is complete. Every process of
// MPI_COMM_WORLD calls it together.
#pragma once

#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>

#include "common/case_file.h"
#include "stokes_solver/resistance_sweep.h"
#include "stokes_solver/stokes.h"

namespace rectify::design
{
  struct DesignResult
  {
    stokes::SweepResult sweep;
    double              k_N_per_m = 0, f1_in_fluid_Hz = 0;
    double              wall_time_s = 0, stiffness_time_s = 0;
    nlohmann::json      manifest;
  };

  /// The case tables and settings a map set depends on: [geometry], [fluid]
  /// (density, viscosity), [reed_material] (values and hashes), and the
  /// [mesh], [flow], [stiffness], [design] settings.
  nlohmann::json map_set_provenance(const CaseFile &file);

  DesignResult run_design(const CaseFile &file, const std::filesystem::path &out_dir,
                          const stokes::MpiSession &mpi);
} // namespace rectify::design
