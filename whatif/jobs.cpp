#include "whatif/jobs.h"

#include <cmath>

#include "common/io.h"
#include "design/design.h"
#include "stokes_solver/parameters.h"
#include "system/parameters.h"
#include "system/sweep.h"

namespace rectify::whatif
{
  namespace fs = std::filesystem;

  const char *kind_name(JobKind k)
  {
    switch (k)
      {
        case JobKind::reed:
          return "reed";
        case JobKind::opening:
          return "opening";
        case JobKind::map_set:
          return "map-set";
        case JobKind::velocity:
          return "velocity";
        case JobKind::pressure:
          return "pressure";
      }
    return "?";
  }


  namespace
  {
    void run_system_sweep(const DesignCase &dc, bool velocity, const BatchSettings &bs, const Paths &paths)
    {
      auto p = system::SystemParameters::from_case(dc.file, false);
      system::use_map_set(p, dc.file, paths.cached(dc.map_set_hash).string());
      const auto &range = velocity ? bs.velocity : bs.pressure;
      auto        s     = system::default_sweep_options(
        p, velocity ? system::Scenario::loaded : system::Scenario::no_flow,
        system::frequency_grid(range.from_Hz, range.to_Hz, range.n, range.log_spacing), bs.cycles);
      s.series = {system::parse_sweep_series("dynamic")};
      if (!velocity)
        {
          s.current_pp_A   = bs.pressure_current_pp_A;
          s.current_bias_A = bs.pressure_current_bias_A;
        }
      s.jobs  = 1; // a rank is one core (mpirun binds it)
      s.quiet = true;
      const fs::path dir = paths.design(dc.design.name) / (velocity ? "velocity" : "pressure");
      ensure_directory(dir);
      const auto  r      = system::run_sweep(p, s, dir);
      const char *metric = velocity ? "mean_velocity_m_per_s" : "stored_pressure_Pa";
      CsvTable    table({"frequency_Hz", metric, "metric_stderr", "settled", "periodic", "valid", "goodman_factor",
                         "max_seat_impact_m_per_s", "max_stop_impact_m_per_s"});
      for (const auto &pt : r.points)
        {
          const double row[9] = {pt.frequency_Hz, velocity ? pt.mean_velocity_m_per_s : pt.stored_pressure_Pa,
                                 pt.metric_stderr, pt.settled ? 1.0 : 0.0, pt.regime == "periodic" ? 1.0 : 0.0,
                                 pt.valid ? 1.0 : 0.0,
                                 std::isfinite(pt.goodman_factor) ? pt.goodman_factor : std::nan(""),
                                 pt.max_seat_impact_m_per_s, pt.max_stop_impact_m_per_s};
          table.add_row(row);
        }
      table.write(dir / "sweep.csv");
      const auto     verdict = sweep_verdict(r.points, velocity);
      const auto     number  = [](double x) { return std::isfinite(x) ? nlohmann::json(x) : nlohmann::json(nullptr); };
      nlohmann::json answer  = {{"points", r.points.size()},
                                {"failed_points", verdict.failed_points},
                                {"valid_points", verdict.valid_points},
                                {"worst_goodman_factor", number(verdict.worst_goodman_factor)},
                                {"max_impact_velocity_m_per_s", verdict.max_impact_velocity_m_per_s},
                                {"survives_to_Hz", number(verdict.survives_to_Hz)},
                                {"valid_to_Hz", number(verdict.valid_to_Hz)},
                                {"range", range.to_json()},
                                {"cycles", bs.cycles},
                                {"series", "dynamic"},
                                {"current_pp_A", s.current_pp_A},
                                {"current_bias_A", s.current_bias_A}};
      const auto &f = verdict.valid_frequencies_Hz, &v = verdict.valid_values;
      if (velocity)
        {
          const auto a   = velocity_answer(f, v), all = velocity_answer(verdict.frequencies_Hz, verdict.values);
          answer["peak_velocity_m_per_s"]         = number(a.peak_velocity_m_per_s);
          answer["peak_velocity_frequency_Hz"]    = number(a.peak_frequency_Hz);
          answer["highest_velocity_m_per_s"]      = number(a.highest_velocity_m_per_s);
          answer["highest_velocity_frequency_Hz"] = number(a.highest_frequency_Hz);
          answer["first_reversal_Hz"]             = number(a.first_reversal_Hz);
          answer["all_points_first_reversal_Hz"]  = number(all.first_reversal_Hz);
          answer["all_points_peak_velocity_m_per_s"] = number(all.peak_velocity_m_per_s);
        }
      else
        {
          const auto a = pressure_answer(f, v), all = pressure_answer(verdict.frequencies_Hz, verdict.values);
          answer["low_frequency_pressure_Pa"]           = number(a.low_frequency_pressure_Pa);
          answer["half_pressure_frequency_Hz"]          = number(a.half_pressure_frequency_Hz);
          answer["all_points_half_pressure_frequency_Hz"] = number(all.half_pressure_frequency_Hz);
        }
      write_json(dir / "answer.json", answer); // last: the job's mark of completion
    }
  } // namespace

  void run_job(const Job &job, const BatchSettings &bs, const std::vector<DesignCase> &designs, const Paths &paths,
               const stokes::MpiSession &group)
  {
    const bool  root = group.rank() == 0;
    const auto &dc   = designs[job.design];
    const auto  work = paths.work(job.hash);
    switch (job.kind)
      {
        case JobKind::reed:
          (void)design::solve_reed_stage(dc.file, work / "reed", root);
          return;
        case JobKind::opening:
          {
            const auto mp = design::flow_mesh_parameters(dc.file, work / "reed");
            const auto fp = stokes::FlowParameters::from_case(dc.file);
            const auto p  = stokes::solve_opening(mp, fp, job.x, group);
            if (!(p.R_Pa_s_per_m3 > 0) || !(p.A_eff_m2 > 0))
              throw std::runtime_error("the Stokes solution at " + format_number(job.x) + " m gives R = " +
                                       format_number(p.R_Pa_s_per_m3) + ", A_eff = " + format_number(p.A_eff_m2));
            if (root)
              {
                ensure_directory(work / "openings");
                write_file_atomic(Paths::opening_file(work, job.x), openings_header() + "\n" + csv_row(p.row()) + "\n");
              }
            return;
          }
        case JobKind::map_set:
          {
            if (!root)
              return;
            const auto rs   = design::ReedStage::from_json(read_json_file(work / "reed" / "reed.json"),
                                                           read_text(work / "reed" / "shape.csv"),
                                                           (work / "reed" / "reed.json").string());
            const auto plan = stokes::plan_resistance_sweep(dc.openings, read_openings(work));
            if (!plan.complete())
              throw std::logic_error("map set " + job.hash + " assembled before its openings were solved");
            double wall = rs.wall_time_s;
            for (const auto &p : plan.result.points)
              wall += p.wall_time_s;
            (void)design::write_map_set(dc.file, work, rs, plan.result, bs.procs_per_job, wall,
                                        "`rectify whatif`, each opening a job on " +
                                          std::to_string(bs.procs_per_job) + " process(es), " +
                                          format_number(std::round(wall)) + " s summed over its jobs");
            publish(work, paths.cached(job.hash));
            return;
          }
        case JobKind::velocity:
        case JobKind::pressure:
          if (root)
            run_system_sweep(dc, job.kind == JobKind::velocity, bs, paths);
          return;
      }
  }
} // namespace rectify::whatif
