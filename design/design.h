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
#include <vector>

#include "common/case_file.h"
#include "maps/map_set.h"
#include "mesher/parameters.h"
#include "stiffness_solver/reed_analysis.h"
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

  /// The reed as the map set needs it: the stiffness solve's numbers, its
  /// bounds, its masses in oil and the FE shape (reed/shape.csv).
  struct ReedStage
  {
    struct Mode
    {
      double      frequency_Hz;
      std::string kind;
      double      modal_mass_kg;
    };
    maps::ReedProperties  reed;
    double                k_N_per_m = 0, plate_mass_kg = 0;
    std::vector<Mode>     modes;
    stiffness::ReedBounds bounds{};
    stiffness::InFluid    fluid{};
    std::string           shape_csv;
    double                wall_time_s = 0;
    /// Everything but the shape (stored beside it: reed/reed.json, reed/shape.csv).
    nlohmann::json   to_json() const;
    static ReedStage from_json(const nlohmann::json &j, std::string shape_csv, const std::string &where);
  };

  /// Stage 1: the reed's stiffness solve. With `write_files`, writes into
  /// `reed_dir` shape.csv, the beam's shape, a plot, reed.vtu and reed.json.
  ReedStage solve_reed_stage(const CaseFile &file, const std::filesystem::path &reed_dir, bool write_files);

  /// The case's mesh parameters with the reed's FE shape (`reed_dir`/shape.csv).
  mesher::MeshParameters flow_mesh_parameters(const CaseFile &file, const std::filesystem::path &reed_dir);

  /// What stage 2's Stokes solves depend on (checkpoints of others are refused).
  nlohmann::json flow_fingerprint(const CaseFile &file, const std::string &shape_csv);

  /// Stage 3: the map set in `out` (which holds reed/ from stage 1) from the
  /// reed and the openings (stokes::resistance_sweep or its plan): tables,
  /// manifest, plots, report. One process. `n_processes` and `wall_time_s`
  /// go into the manifest; `made_by` says in the report what made it and
  /// what its time means ("`rectify design`, 2 process(es), 243 s wall").
  DesignResult write_map_set(const CaseFile &file, const std::filesystem::path &out, const ReedStage &reed,
                             const stokes::SweepResult &sweep, unsigned n_processes, double wall_time_s,
                             const std::string &made_by);

  /// The case tables and settings a map set depends on: [geometry], [fluid]
  /// (density, viscosity), [reed_material] (values and hashes), and the
  /// [mesh], [flow], [stiffness], [design] settings.
  nlohmann::json map_set_provenance(const CaseFile &file);

  DesignResult run_design(const CaseFile &file, const std::filesystem::path &out_dir,
                          const stokes::MpiSession &mpi);
} // namespace rectify::design
