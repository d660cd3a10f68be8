// `rectify whatif`: design what-ifs over many valve designs, one batch of
// jobs on MPI (whatif/). Run with `mpirun -np N rectify whatif ...`.
#include <cstdio>
#include <fstream>
#include <set>
#include <sstream>

#include "app/commands.h"
#include "app/fe_lock.h"
#include "common/io.h"
#include "whatif/batch.h"

namespace rectify::app
{
  namespace
  {
    struct WhatifOptions
    {
      std::string              case_path;
      std::string              out_dir;
      std::vector<std::string> vary;
      std::string              designs_table;
      std::string              cache_dir;
      unsigned                 procs_per_job = 1;
      std::string              velocity_sweep = "10:3500:100:linear";
      std::string              pressure_sweep = "1:1200:40:log";
      std::size_t              cycles         = 50;
      std::string              reed_loading   = "auto";
    };

    void whatif_command(const WhatifOptions &o)
    {
      // Every design is read and checked before MPI starts a single job.
      whatif::BatchSettings bs;
      bs.case_path = o.case_path;
      (void)load_case(o.case_path, false);
      {
        std::ifstream      in(o.case_path);
        std::ostringstream text;
        text << in.rdbuf();
        bs.case_text = text.str();
      }
      if (!o.vary.empty() && !o.designs_table.empty())
        throw InputError("whatif: give --vary or --designs, not both");
      if (!o.designs_table.empty())
        bs.designs = whatif::read_designs_table(o.designs_table);
      else
        {
          std::vector<whatif::Variation> variations;
          for (const auto &v : o.vary)
            variations.push_back(whatif::parse_variation(v));
          bs.designs = whatif::grid_designs(variations);
        }
      bs.out_dir       = o.out_dir;
      bs.cache_dir     = o.cache_dir.empty() ? whatif::default_cache_dir() : std::filesystem::path(o.cache_dir);
      bs.velocity      = whatif::parse_frequency_range(o.velocity_sweep, "--velocity-sweep", false);
      bs.pressure      = whatif::parse_frequency_range(o.pressure_sweep, "--pressure-sweep", true);
      bs.procs_per_job = o.procs_per_job;
      if (o.cycles == 0)
        throw InputError("--cycles 0: must be >= 1");
      bs.cycles       = o.cycles;
      bs.reed_loading = o.reed_loading;
      const auto designs =
        whatif::read_design_cases(bs, [](const CaseFile &file) { check_every_stage(file, false); });

      stokes::MpiSession mpi(stokes::MpiSession::Threads::multiple);
      const bool         root = mpi.rank() == 0;
      if (root)
        {
          std::size_t n_sets = 0;
          {
            std::set<std::string> hashes;
            for (const auto &d : designs)
              hashes.insert(d.map_set_hash);
            n_sets = hashes.size();
          }
          echo_settings("whatif", {{"case", o.case_path},
                                   {"designs", std::to_string(designs.size()) + " (" + std::to_string(n_sets) +
                                                 " distinct map sets)"},
                                   {"velocity sweep", bs.velocity.to_json().dump()},
                                   {"pressure sweep", bs.pressure.to_json().dump() + " at " +
                                                        format_number(bs.pressure_current_pp_A) + " A p-p, " +
                                                        format_number(bs.pressure_current_bias_A) + " A bias"},
                                   {"processes", std::to_string(mpi.size()) + ", " + std::to_string(o.procs_per_job) +
                                                   " per job"},
                                   {"map-set cache", bs.cache_dir.string()},
                                   {"output", o.out_dir}});
        }
      OutputLock lock;
      lock_on_root(lock, o.out_dir, mpi, true);
      const auto r = whatif::run_batch(bs, designs, mpi);
      if (!root)
        return;
      std::printf("whatif %s: %zu designs, %zu failed; %zu map sets (%zu were in the cache); %zu jobs run here, %zu "
                  "failed; %.0f s. Table: %s/whatif.csv\n",
                  o.out_dir.c_str(), r.n_designs, r.n_failed, r.n_map_sets, r.n_map_sets_cached, r.n_jobs_run,
                  r.n_jobs_failed, r.wall_time_s, o.out_dir.c_str());
    }
  } // namespace

  void register_whatif_command(CLI::App &app)
  {
    auto  o   = std::make_shared<WhatifOptions>();
    auto *cmd = app.add_subcommand(
      "whatif",
      "Design what-ifs: many valve designs, each its map set (cached by provenance) and the system's answer\n"
      "(loaded velocity sweep: peak velocity, first reversal = bandwidth; no-flow stored-pressure sweep: where it\n"
      "halves), one batch of jobs on MPI: resumable, a slow job does not hold the others. docs/whatif.md.\n"
      "Example: mpirun -np 2 rectify whatif --vary geometry.reed_thickness_m=0.08e-3:0.25e-3:10 --out runs/thick");
    add_case_and_out(*cmd, o->case_path, o->out_dir);
    cmd->add_option("--vary", o->vary,
                    "a grid axis, table.key=FROM:TO:N[:log] (repeat for a grid over several keys)");
    cmd->add_option("--designs", o->designs_table,
                    "a designs table (CSV): a column per case key (table.key), a row per design, an optional "
                    "'name' column");
    cmd->add_option("--cache", o->cache_dir,
                    "finished map sets, by provenance hash, shared between batches (default: $RECTIFY_CACHE, "
                    "else ~/.cache/rectify/map-sets)");
    cmd->add_option("--procs-per-job", o->procs_per_job, "MPI processes per FE job (must divide -np)")
      ->capture_default_str()
      ->check(CLI::Range(1u, 4096u));
    cmd->add_option("--velocity-sweep", o->velocity_sweep, "the loaded sweep, FROM:TO:N[:log|linear] in Hz")
      ->capture_default_str();
    cmd->add_option("--pressure-sweep", o->pressure_sweep, "the no-flow sweep (4 A p-p, 2 A bias), FROM:TO:N[:log|linear]")
      ->capture_default_str();
    cmd->add_option("--cycles", o->cycles, "measured cycles per sweep point, after settling")->capture_default_str();
    cmd->add_option("--reed-loading", o->reed_loading,
                    "auto: each map set solves the reed's fluid loading only if its design's system model reads it "
                    "([reed] fluid_loading = \"map\"); case: as the case's [flow] reed_loading says")
      ->check(CLI::IsMember({"auto", "case"}))
      ->capture_default_str();
    cmd->callback([o]() { whatif_command(*o); });
  }
} // namespace rectify::app
