#include "whatif/batch.h"

#include <mpi.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <sstream>
#include <thread>

#include "common/io.h"
#include "common/version.h"
#include "design/design.h"
#include "maps/map_set.h"
#include "stokes_solver/parameters.h"
#include "system/parameters.h"
#include "system/sweep.h"
#include "whatif/paths.h"
#include "whatif/scheduler.h"
#include "whatif/summary.h"
#include "whatif/transport.h"

namespace rectify::whatif
{
  namespace fs = std::filesystem;

  // ------------------------------------------------------------- public
  nlohmann::json FrequencyRange::to_json() const
  {
    return {{"from_Hz", from_Hz}, {"to_Hz", to_Hz}, {"n", n}, {"spacing", log_spacing ? "log" : "linear"}};
  }

  FrequencyRange parse_frequency_range(const std::string &spec, const std::string &option, bool default_log)
  {
    std::vector<std::string> parts;
    {
      std::stringstream in(spec);
      for (std::string p; std::getline(in, p, ':');)
        parts.push_back(p);
    }
    FrequencyRange r;
    r.log_spacing = default_log;
    if (parts.size() == 4 && (parts[3] == "log" || parts[3] == "linear"))
      {
        r.log_spacing = parts[3] == "log";
        parts.pop_back();
      }
    const auto fail = [&](const std::string &why) {
      throw InputError(option + " '" + spec + "': " + why + " (expected FROM:TO:N[:log|linear] in Hz)");
    };
    if (parts.size() != 3)
      fail("three fields needed");
    try
      {
        std::size_t used = 0;
        r.from_Hz        = std::stod(parts[0], &used);
        if (used != parts[0].size())
          fail("FROM is not a number");
        r.to_Hz = std::stod(parts[1], &used);
        if (used != parts[1].size())
          fail("TO is not a number");
        const long n = std::stol(parts[2], &used);
        if (used != parts[2].size() || n < 2)
          fail("N must be a whole number >= 2");
        r.n = static_cast<std::size_t>(n);
      }
    catch (const std::logic_error &)
      {
        fail("not numbers");
      }
    if (!(r.from_Hz > 0) || !std::isfinite(r.to_Hz) || !(r.to_Hz > r.from_Hz))
      fail("needs 0 < FROM < TO");
    return r;
  }

  nlohmann::json BatchSettings::definition() const
  {
    nlohmann::json d = nlohmann::json::array();
    for (const auto &x : designs)
      d.push_back({{"name", x.name}, {"values", x.values()}});
    return {{"case_hash", content_hash(case_text)},
            {"designs", d},
            {"velocity_sweep", velocity.to_json()},
            {"pressure_sweep", pressure.to_json()},
            {"pressure_current_pp_A", pressure_current_pp_A},
            {"pressure_current_bias_A", pressure_current_bias_A},
            {"cycles", cycles},
            {"reed_loading", reed_loading},
            {"rectify_version", RECTIFY_VERSION}};
  }

  std::string map_set_hash(const CaseFile &file)
  {
    return content_hash(nlohmann::json{{"map_set", design::map_set_provenance(file)},
                                       {"openings", stokes::SweepSettings::from_case(file).to_json()},
                                       {"rectify_version", RECTIFY_VERSION}}
                          .dump());
  }

  std::vector<DesignCase> read_design_cases(const BatchSettings &settings,
                                            const std::function<void(const CaseFile &)> &check)
  {
    if (settings.designs.empty())
      throw InputError("whatif: no designs (give --vary or --designs)");
    if (settings.reed_loading != "auto" && settings.reed_loading != "case")
      throw InputError("--reed-loading " + settings.reed_loading + ": expected auto or case");
    const fs::path          base_dir = fs::absolute(settings.case_path).parent_path();
    std::vector<DesignCase> cases;
    for (const auto &d : settings.designs)
      {
        std::string values;
        for (std::size_t i = 0; i < d.entries.size(); ++i)
          values += (i ? ", " : "") + d.entries[i].table + "." + d.entries[i].key + " = " + d.text_values[i];
        const std::string name = settings.case_path.string() + " with design " + d.name + " (" + values + ")";
        Design            with = d;
        const bool design_sets_it = std::any_of(d.entries.begin(), d.entries.end(), [](const CaseEntry &e) {
          return e.table == "flow" && e.key == "reed_loading";
        });
        if (settings.reed_loading == "auto" && !design_sets_it)
          {
            // The map set's loading table only if the design's system model reads it.
            const bool map = system::SystemParameters::from_case(
                               CaseFile::parse(design_case_text(settings.case_text, base_dir, d), name, base_dir), false)
                               .reed.fluid_loading == "map";
            with.entries.push_back({"flow", "reed_loading", map ? "\"solve\"" : "\"skip\"", ""});
            with.text_values.push_back(map ? "solve" : "skip");
          }
        const std::string text = design_case_text(settings.case_text, base_dir, with);
        const CaseFile    file = CaseFile::parse(text, name, base_dir);
        check(file);
        const auto system = system::SystemParameters::from_case(file, false);
        if (system.drive.waveform != "sine")
          throw InputError(file.where("drive", "waveform") + ": the what-if's sweeps need the sine drive");
        cases.push_back({d, file, text, map_set_hash(file), stokes::SweepSettings::from_case(file)});
      }
    return cases;
  }

  fs::path default_cache_dir()
  {
    if (const char *c = std::getenv("RECTIFY_CACHE"); c != nullptr && *c != '\0')
      return c;
    if (const char *x = std::getenv("XDG_CACHE_HOME"); x != nullptr && *x != '\0')
      return fs::path(x) / "rectify" / "map-sets";
    if (const char *h = std::getenv("HOME"); h != nullptr && *h != '\0')
      return fs::path(h) / ".cache" / "rectify" / "map-sets";
    return fs::temp_directory_path() / "rectify-map-sets";
  }

  SweepVerdict sweep_verdict(const std::vector<system::SweepPoint> &points, bool velocity)
  {
    SweepVerdict d;
    d.points          = points.size();
    bool survives     = true, valid = true;
    for (const auto &pt : points)
      {
        const double value = velocity ? pt.mean_velocity_m_per_s : pt.stored_pressure_Pa;
        if (pt.failed() || !std::isfinite(value))
          {
            ++d.failed_points;
            continue;
          }
        d.frequencies_Hz.push_back(pt.frequency_Hz);
        d.values.push_back(value);
        d.worst_goodman_factor        = std::min(d.worst_goodman_factor, pt.goodman_factor);
        d.max_impact_velocity_m_per_s = std::max({d.max_impact_velocity_m_per_s, pt.max_seat_impact_m_per_s,
                                                  pt.max_stop_impact_m_per_s});
        survives = survives && !pt.goodman_below_1;
        valid    = valid && pt.valid;
        if (survives)
          d.survives_to_Hz = pt.frequency_Hz;
        if (valid)
          d.valid_to_Hz = pt.frequency_Hz;
        if (pt.valid)
          {
            ++d.valid_points;
            d.valid_frequencies_Hz.push_back(pt.frequency_Hz);
            d.valid_values.push_back(value);
          }
      }
    return d;
  }

  VelocityAnswer velocity_answer(const std::vector<double> &f, const std::vector<double> &v)
  {
    VelocityAnswer a;
    const double   nan = std::nan("");
    a.first_reversal_Hz = nan;
    if (f.empty())
      {
        a.peak_velocity_m_per_s = a.peak_frequency_Hz = a.highest_velocity_m_per_s = a.highest_frequency_Hz = nan;
        return a;
      }
    std::size_t band_end = f.size(); // the points below the first reversal
    for (std::size_t i = 1; i < f.size(); ++i)
      if (v[i - 1] > 0 && v[i] <= 0)
        {
          a.first_reversal_Hz = f[i - 1] + (f[i] - f[i - 1]) * v[i - 1] / (v[i - 1] - v[i]);
          band_end            = i;
          break;
        }
    const auto peak = static_cast<std::size_t>(std::max_element(v.begin(), v.begin() + static_cast<long>(band_end)) -
                                               v.begin());
    const auto highest = static_cast<std::size_t>(std::max_element(v.begin(), v.end()) - v.begin());
    a.peak_velocity_m_per_s    = v[peak];
    a.peak_frequency_Hz        = f[peak];
    a.highest_velocity_m_per_s = v[highest];
    a.highest_frequency_Hz     = f[highest];
    return a;
  }

  PressureAnswer pressure_answer(const std::vector<double> &f, const std::vector<double> &p)
  {
    PressureAnswer a;
    a.half_pressure_frequency_Hz = std::nan("");
    if (f.empty())
      {
        a.low_frequency_pressure_Pa = std::nan("");
        return a;
      }
    a.low_frequency_pressure_Pa = p[0];
    const double half           = 0.5 * p[0];
    for (std::size_t i = 1; i < f.size(); ++i)
      if (p[i - 1] > half && p[i] <= half)
        {
          const double t = (p[i - 1] - half) / (p[i - 1] - p[i]);
          a.half_pressure_frequency_Hz = std::exp(std::log(f[i - 1]) + t * (std::log(f[i]) - std::log(f[i - 1])));
          break;
        }
    return a;
  }

  BatchReport run_batch(const BatchSettings &bs, const std::vector<DesignCase> &designs, const stokes::MpiSession &world)
  {
    const auto start = Clock::now();
    const Paths paths{fs::absolute(bs.out_dir), fs::absolute(bs.cache_dir)};
    const int   rank = static_cast<int>(world.rank()), size = static_cast<int>(world.size());
    if (bs.procs_per_job < 1 || size % static_cast<int>(bs.procs_per_job) != 0)
      throw InputError("--procs-per-job " + std::to_string(bs.procs_per_job) + ": must divide the number of processes (" +
                       std::to_string(size) + ")");
    const unsigned n_groups = static_cast<unsigned>(size) / bs.procs_per_job;

    // The batch's folder: its definition (a restart must match it) and each design's case.
    std::string error;
    if (rank == 0)
      try
        {
          const auto definition = bs.definition();
          const auto file       = paths.out / "batch.json";
          if (fs::exists(file))
            {
              const auto old = read_json_file(file);
              if (old != definition)
                {
                  std::string what = "settings";
                  for (const auto &[k, v] : definition.items())
                    if (!old.contains(k) || old[k] != v)
                      {
                        what = k;
                        break;
                      }
                  throw InputError("'" + paths.out.string() + "' holds a batch with other " + what +
                                   " (batch.json): start it again with its own command, or choose another --out");
                }
            }
          else
            write_json(file, definition);
          for (const auto &dc : designs)
            {
              ensure_directory(paths.design(dc.design.name));
              write_file_atomic(paths.design(dc.design.name) / "case.toml", dc.case_text);
            }
          ensure_directory(paths.cache);
        }
      catch (const std::exception &e)
        {
          error = e.what();
        }
    if (world.broadcast({error.empty() ? 1.0 : 0.0})[0] == 0.0)
      throw InputError(rank == 0 ? error : "the batch could not start (the first process says why)");

    MPI_Comm sched = MPI_COMM_NULL, group = MPI_COMM_NULL;
    MPI_Comm_dup(world.comm(), &sched);
    MPI_Comm_split(world.comm(), rank / static_cast<int>(bs.procs_per_job), rank, &group);
    BatchReport report;
    if (rank == 0)
      {
        Scheduler   scheduler(designs, paths, n_groups);
        std::thread thread([&]() {
          try
            {
              schedule(scheduler, sched, n_groups);
            }
          catch (const std::exception &e)
            {
              std::fprintf(stderr, "rectify whatif: the scheduler failed: %s\n", e.what());
              MPI_Abort(MPI_COMM_WORLD, 1);
            }
        });
        serve(bs, designs, paths, sched, group);
        thread.join();
        report = scheduler.report;
      }
    else
      serve(bs, designs, paths, sched, group);
    MPI_Comm_free(&group);
    MPI_Comm_free(&sched);
    if (rank != 0)
      return report;
    std::error_code ec;
    fs::remove(paths.out / "work", ec); // if empty: every map set is in the cache

    report.n_failed  = write_summary(bs, designs, paths);
    report.n_designs = designs.size();
    report.wall_time_s = seconds_since(start);
    write_json(paths.out / "run.json", {{"finished", utc_now()},
                                        {"wall_time_s", report.wall_time_s},
                                        {"processes", size},
                                        {"procs_per_job", bs.procs_per_job},
                                        {"jobs_run", report.n_jobs_run},
                                        {"jobs_failed", report.n_jobs_failed},
                                        {"map_sets", report.n_map_sets},
                                        {"map_sets_found_in_cache", report.n_map_sets_cached},
                                        {"cache", paths.cache.string()}});
    return report;
  }
} // namespace rectify::whatif

