#include "whatif/batch.h"

#include <mpi.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <deque>
#include <fstream>
#include <map>
#include <optional>
#include <set>
#include <sstream>
#include <thread>
#include <unistd.h>

#include "common/io.h"
#include "common/plot.h"
#include "common/version.h"
#include "design/design.h"
#include "maps/map_set.h"
#include "stokes_solver/parameters.h"
#include "system/parameters.h"
#include "system/sweep.h"

namespace rectify::whatif
{
  namespace fs = std::filesystem;

  namespace
  {
    using Clock = std::chrono::steady_clock;
    double seconds_since(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }

    std::string exact(double x)
    {
      char buf[40];
      std::snprintf(buf, sizeof(buf), "%.17g", x);
      return buf;
    }

    std::string read_text(const fs::path &path)
    {
      std::ifstream in(path);
      if (!in)
        throw InputError("'" + path.string() + "' cannot be read");
      std::ostringstream s;
      s << in.rdbuf();
      return s.str();
    }

    nlohmann::json read_json_file(const fs::path &path)
    {
      try
        {
          return nlohmann::json::parse(read_text(path));
        }
      catch (const nlohmann::json::exception &e)
        {
          throw InputError("'" + path.string() + "': malformed JSON (" + e.what() + ")");
        }
    }

    // ------------------------------------------------------------- the files
    struct Paths
    {
      fs::path out, cache;
      fs::path work(const std::string &hash) const { return out / "work" / hash; }
      fs::path cached(const std::string &hash) const { return cache / hash; }
      fs::path design(const std::string &name) const { return out / "designs" / name; }
      fs::path failures() const { return out / "failures"; }
      static fs::path opening_file(const fs::path &work, double x) { return work / "openings" / ("x-" + exact(x) + ".csv"); }
      bool map_set_done(const std::string &hash) const { return fs::exists(cached(hash) / "manifest.json"); }
    };

    std::string openings_header()
    {
      std::string header;
      for (const auto &c : stokes::OpeningPoint::columns())
        header += (header.empty() ? "" : ",") + c;
      return header;
    }

    /// One opening's record (an opening job's result).
    stokes::OpeningPoint read_opening(const fs::path &file)
    {
      const auto csv = read_csv(file);
      if (csv.columns != stokes::OpeningPoint::columns() || csv.rows.size() != 1)
        throw InputError("'" + file.string() + "': not one opening's record (columns " + openings_header() + ")");
      return stokes::OpeningPoint::from_row(csv.rows[0]);
    }

    /// The openings solved so far for a map set in the making.
    std::map<double, stokes::OpeningPoint> read_openings(const fs::path &work)
    {
      std::map<double, stokes::OpeningPoint> points;
      const fs::path                         dir = work / "openings";
      if (!fs::exists(dir))
        return points;
      for (const auto &entry : fs::directory_iterator(dir))
        {
          const std::string name = entry.path().filename().string();
          if (name.rfind("x-", 0) != 0 || entry.path().extension() != ".csv")
            continue; // a temporary a kill left
          const auto p        = read_opening(entry.path());
          points[p.opening_m] = p;
        }
      return points;
    }

    /// A failed job's record (failures/JOB.json).
    struct Failure
    {
      std::string              job, reason;
      std::vector<std::string> designs;
    };

    /// Every failure recorded in the batch's folder, by file name.
    std::vector<Failure> read_failures(const Paths &paths)
    {
      std::vector<fs::path> files;
      if (fs::exists(paths.failures()))
        for (const auto &e : fs::directory_iterator(paths.failures()))
          if (e.path().extension() == ".json")
            files.push_back(e.path());
      std::sort(files.begin(), files.end());
      std::vector<Failure> failures;
      for (const auto &f : files)
        try
          {
            const auto j = read_json_file(f);
            failures.push_back({j.at("job").get<std::string>(), j.at("reason").get<std::string>(),
                                j.at("designs").get<std::vector<std::string>>()});
          }
        catch (const nlohmann::json::exception &e)
          {
            throw InputError("'" + f.string() + "': not a failure record (" + e.what() + ")");
          }
      return failures;
    }

    /// Moves a finished map set from the batch's work folder into the cache.
    void publish(const fs::path &from, const fs::path &to)
    {
      ensure_directory(to.parent_path());
      for (int attempt = 0; attempt < 2; ++attempt)
        {
          std::error_code ec;
          fs::rename(from, to, ec);
          if (!ec)
            return;
          if (fs::exists(to / "manifest.json"))
            {
              fs::remove_all(from); // another batch with this cache made it meanwhile
              return;
            }
          if (fs::exists(to))
            {
              fs::remove_all(to); // what a killed copy left
              continue;
            }
          if (ec == std::errc::cross_device_link)
            {
              const fs::path part = to.parent_path() / (to.filename().string() + ".part." + std::to_string(getpid()));
              fs::remove_all(part);
              fs::copy(from, part, fs::copy_options::recursive);
              fs::rename(part, to);
              fs::remove_all(from);
              return;
            }
          throw std::runtime_error("cannot move the map set '" + from.string() + "' into the cache '" + to.string() +
                                   "': " + ec.message());
        }
    }

    // ------------------------------------------------------------- jobs
    enum class JobKind
    {
      reed,
      opening,
      map_set,
      velocity,
      pressure
    };

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

    struct Job
    {
      JobKind     kind   = JobKind::reed;
      std::string hash;       ///< the map set's (FE jobs)
      std::size_t design = 0; ///< the design (sweeps), or the first design of the map set
      double      x      = 0; ///< the opening

      /// "reed:HASH", "opening:HASH:X", "map-set:HASH", "velocity:NAME", "pressure:NAME".
      std::string id(const std::vector<DesignCase> &designs) const
      {
        switch (kind)
          {
            case JobKind::reed:
            case JobKind::map_set:
              return std::string(kind_name(kind)) + ":" + hash;
            case JobKind::opening:
              return "opening:" + hash + ":" + exact(x);
            default:
              return std::string(kind_name(kind)) + ":" + designs[design].design.name;
          }
      }
      std::string to_text() const
      {
        return nlohmann::json{{"kind", static_cast<int>(kind)}, {"hash", hash}, {"design", design}, {"x", exact(x)}}
          .dump();
      }
      static Job from_text(const std::string &text)
      {
        const auto j = nlohmann::json::parse(text);
        Job        job;
        job.kind   = static_cast<JobKind>(j.at("kind").get<int>());
        job.hash   = j.at("hash").get<std::string>();
        job.design = j.at("design").get<std::size_t>();
        job.x      = std::stod(j.at("x").get<std::string>());
        return job;
      }
    };

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

    // ------------------------------------------------------------- the queue
    /// The batch's state and its next ready job. Lives on rank 0, used by the
    /// scheduler thread alone. Built from the files, so a restarted batch
    /// takes up exactly what is left.
    class Scheduler
    {
    public:
      Scheduler(const std::vector<DesignCase> &designs, const Paths &paths, unsigned n_groups)
        : designs_(designs)
        , paths_(paths)
        , n_groups_(n_groups)
        , log_(paths.out / "jobs.log", std::ios::app)
      {
        std::map<std::string, std::string> failures; // job id -> reason
        for (const auto &f : read_failures(paths))
          failures[f.job] = f.reason;
        for (std::size_t i = 0; i < designs.size(); ++i)
          {
            const auto &h = designs[i].map_set_hash;
            if (!sets_.contains(h))
              {
                SetState s;
                s.design = i;
                s.done   = paths.map_set_done(h);
                if (s.done)
                  ++report.n_map_sets_cached;
                else
                  {
                    s.reed_done = fs::exists(paths.work(h) / "reed" / "reed.json");
                    s.solved    = read_openings(paths.work(h));
                  }
                for (const auto &[id, reason] : failures)
                  if (id == "reed:" + h || id == "map-set:" + h || id.rfind("opening:" + h + ":", 0) == 0)
                    s.failure = reason;
                sets_[h] = std::move(s);
              }
            DesignState d;
            for (int v = 0; v < 2; ++v)
              {
                const std::string kind = v == 0 ? "velocity" : "pressure";
                d.done[v] = fs::exists(paths.design(designs[i].design.name) / kind / "answer.json");
                if (const auto it = failures.find(kind + ":" + designs[i].design.name); it != failures.end())
                  d.failure[v] = it->second;
              }
            states_.push_back(d);
          }
        report.n_map_sets = sets_.size();
        for (const auto &[h, s] : sets_)
          n_done_before_ += s.done ? 0 : (s.reed_done ? 1 : 0) + s.solved.size();
        for (const auto &d : states_)
          n_done_before_ += d.done[0] + d.done[1];
        log("batch started: " + std::to_string(designs.size()) + " designs, " + std::to_string(sets_.size()) +
            " map sets (" + std::to_string(report.n_map_sets_cached) + " found finished in the cache), " +
            std::to_string(n_done_before_) + " jobs found finished");
      }

      /// The next ready job (marked running on `leader`), or nothing.
      std::optional<Job> next(int leader)
      {
        for (std::size_t i = 0; i < designs_.size(); ++i)
          {
            auto &s = sets_.at(designs_[i].map_set_hash);
            if (!s.failure.empty())
              continue;
            if (!s.done)
              {
                if (auto job = set_job(s, designs_[i].map_set_hash))
                  return dispatch(*job, leader);
                continue;
              }
            auto &d = states_[i];
            for (int v = 0; v < 2; ++v)
              if (!d.done[v] && !d.running[v] && d.failure[v].empty())
                {
                  d.running[v] = true;
                  return dispatch({v == 0 ? JobKind::velocity : JobKind::pressure, designs_[i].map_set_hash, i, 0},
                                  leader);
                }
          }
        return std::nullopt;
      }

      /// The job `leader` ran has ended.
      void finish(int leader, bool ok, const std::string &reason, double wall_s)
      {
        const Job job = running_.at(leader);
        running_.erase(leader);
        const std::string id = job.id(designs_);
        ++report.n_jobs_run;
        times_[job.kind].first += wall_s;
        times_[job.kind].second += 1;
        auto &s = sets_.at(job.hash);
        if (!ok)
          {
            ++report.n_jobs_failed;
            std::vector<std::string> names;
            const bool sweep = job.kind == JobKind::velocity || job.kind == JobKind::pressure;
            for (std::size_t i = 0; i < designs_.size(); ++i)
              if (sweep ? i == job.design : designs_[i].map_set_hash == job.hash)
                names.push_back(designs_[i].design.name);
            std::string file = id;
            std::replace(file.begin(), file.end(), ':', '_');
            ensure_directory(paths_.failures());
            write_json(paths_.failures() / (file + ".json"), {{"job", id}, {"designs", names}, {"reason", reason}});
          }
        switch (job.kind)
          {
            case JobKind::reed:
              s.reed_running = false;
              s.reed_done    = ok;
              break;
            case JobKind::opening:
              s.running.erase(job.x);
              if (ok)
                {
                  s.solved[job.x] = read_opening(Paths::opening_file(paths_.work(job.hash), job.x));
                  s.plan.reset();
                }
              break;
            case JobKind::map_set:
              s.assembling = false;
              s.done       = ok && paths_.map_set_done(job.hash);
              if (ok && !s.done)
                throw std::runtime_error("map set " + job.hash + " assembled but not found in the cache");
              if (s.done)
                n_openings_made_.push_back(s.solved.size());
              break;
            case JobKind::velocity:
            case JobKind::pressure:
              {
                const int v            = job.kind == JobKind::velocity ? 0 : 1;
                states_[job.design].running[v] = false;
                states_[job.design].done[v]    = ok;
                if (!ok)
                  states_[job.design].failure[v] = reason;
                break;
              }
          }
        if (!ok && job.kind != JobKind::velocity && job.kind != JobKind::pressure)
          s.failure = reason;
        log(std::string(ok ? "done " : "failed ") + id + " rank " + std::to_string(leader) + " " +
            format_fixed(wall_s, 1) + " s" + (ok ? "" : ": " + reason));
        progress(job, leader, ok, wall_s, reason);
      }

      std::size_t n_running() const { return running_.size(); }
      BatchReport report;

    private:
      struct SetState
      {
        std::size_t                            design = 0;
        bool                                   done = false, reed_done = false, reed_running = false,
                                               assembling = false;
        std::map<double, stokes::OpeningPoint> solved;
        std::set<double>                       running;
        std::string                            failure;
        /// The plan for `solved` (made again only when an opening is added:
        /// a queue of many designs asks for it at every dispatch).
        std::optional<stokes::SweepPlan>       plan;
      };
      struct DesignState
      {
        bool        done[2]    = {false, false}; ///< velocity, pressure
        bool        running[2] = {false, false};
        std::string failure[2];
      };

      std::optional<Job> set_job(SetState &s, const std::string &hash)
      {
        if (!s.reed_done)
          {
            if (s.reed_running)
              return std::nullopt;
            s.reed_running = true;
            return Job{JobKind::reed, hash, s.design, 0};
          }
        if (s.assembling)
          return std::nullopt;
        if (!s.plan)
          s.plan = stokes::plan_resistance_sweep(designs_[s.design].openings, s.solved);
        const auto &plan = *s.plan;
        if (plan.complete())
          {
            if (!s.running.empty())
              return std::nullopt;
            s.assembling = true;
            return Job{JobKind::map_set, hash, s.design, 0};
          }
        for (double x : plan.missing)
          if (!s.running.contains(x))
            {
              s.running.insert(x);
              return Job{JobKind::opening, hash, s.design, x};
            }
        return std::nullopt;
      }

      Job dispatch(const Job &job, int leader)
      {
        running_[leader] = job;
        log("start " + job.id(designs_) + " rank " + std::to_string(leader));
        return job;
      }

      static std::string format_fixed(double v, int digits)
      {
        char buf[64];
        std::snprintf(buf, sizeof(buf), "%.*f", digits, v);
        return buf;
      }

      void log(const std::string &line)
      {
        log_ << utc_now() << " " << line << "\n";
        log_.flush();
      }

      /// Jobs left, estimated: a map set in the making needs as many
      /// openings as those finished in this batch did (else 4x its coarse grid).
      double jobs_left() const
      {
        double mean_openings = 0;
        for (auto n : n_openings_made_)
          mean_openings += static_cast<double>(n) / static_cast<double>(n_openings_made_.size());
        double left = 0;
        for (const auto &[h, s] : sets_)
          if (!s.done && s.failure.empty())
            {
              const double expected =
                n_openings_made_.empty() ? 4.0 * designs_[s.design].openings.initial_openings : mean_openings;
              left += (s.reed_done ? 0 : 1) + 1 +
                      std::max(0.0, expected - static_cast<double>(s.solved.size() + s.running.size()));
            }
        for (std::size_t i = 0; i < states_.size(); ++i)
          if (sets_.at(designs_[i].map_set_hash).failure.empty())
            for (int v = 0; v < 2; ++v)
              left += !states_[i].done[v] && !states_[i].running[v] && states_[i].failure[v].empty();
        return left + static_cast<double>(running_.size());
      }

      void progress(const Job &job, int leader, bool ok, double wall_s, const std::string &reason)
      {
        double per_job = 0, n = 0;
        for (const auto &[k, t] : times_)
          per_job += t.first, n += t.second;
        per_job = n > 0 ? per_job / n : 0;
        const double left  = jobs_left();
        const double eta_s = left * per_job / std::max(1u, n_groups_);
        std::string  what  = std::string(kind_name(job.kind)) + " of " + designs_[job.design].design.name;
        if (job.kind == JobKind::opening)
          what += " at " + format_fixed(job.x * 1e6, 2) + " um";
        std::fprintf(stderr,
                     "whatif: %zu jobs done here (%zu before), %zu failed, %zu running, ~%.0f left, ETA %s | %s on "
                     "rank %d: %.1f s%s%s\n",
                     report.n_jobs_run, n_done_before_, report.n_jobs_failed, running_.size(), left,
                     eta_s < 120 ? (format_fixed(eta_s, 0) + " s").c_str() : (format_fixed(eta_s / 60, 0) + " min").c_str(),
                     what.c_str(), leader, wall_s, ok ? "" : ", FAILED: ", ok ? "" : reason.c_str());
      }

      const std::vector<DesignCase>          &designs_;
      const Paths                            &paths_;
      unsigned                                n_groups_;
      std::ofstream                           log_;
      std::map<std::string, SetState>         sets_;
      std::vector<DesignState>                states_;
      std::map<int, Job>                      running_; ///< by the group leader's rank
      std::map<JobKind, std::pair<double, double>> times_;
      std::vector<std::size_t>                n_openings_made_;
      std::size_t                             n_done_before_ = 0;
    };

    // ------------------------------------------------------------- MPI
    constexpr int tag_request = 1, tag_job = 2;

    /// Waits without spinning a core: an idle rank must not take the CPU a
    /// working one on the same core needs (and rank 0's scheduler shares a core).
    void pause_briefly() { std::this_thread::sleep_for(std::chrono::milliseconds(2)); }

    void send_string(MPI_Comm comm, int dest, int tag, const std::string &s)
    {
      MPI_Send(s.data(), static_cast<int>(s.size()), MPI_CHAR, dest, tag, comm);
    }

    std::string receive_string(MPI_Comm comm, MPI_Status status)
    {
      int n = 0;
      MPI_Get_count(&status, MPI_CHAR, &n);
      std::string s(static_cast<std::size_t>(n), '\0');
      MPI_Recv(s.data(), n, MPI_CHAR, status.MPI_SOURCE, status.MPI_TAG, comm, MPI_STATUS_IGNORE);
      return s;
    }

    std::string wait_for_string(MPI_Comm comm, int source, int tag)
    {
      for (;;)
        {
          int        flag = 0;
          MPI_Status status;
          MPI_Iprobe(source, tag, comm, &flag, &status);
          if (flag)
            return receive_string(comm, status);
          pause_briefly();
        }
    }

    void wait(MPI_Request &request)
    {
      for (int done = 0;;)
        {
          MPI_Test(&request, &done, MPI_STATUS_IGNORE);
          if (done)
            return;
          pause_briefly();
        }
    }

    std::string broadcast_string(MPI_Comm group, std::string s)
    {
      int size = 1;
      MPI_Comm_size(group, &size);
      if (size == 1)
        return s;
      long        n = static_cast<long>(s.size());
      MPI_Request r;
      MPI_Ibcast(&n, 1, MPI_LONG, 0, group, &r);
      wait(r);
      s.resize(static_cast<std::size_t>(n));
      MPI_Ibcast(s.data(), static_cast<int>(n), MPI_CHAR, 0, group, &r);
      wait(r);
      return s;
    }

    /// Rank 0's scheduler thread: answers every group leader's request with
    /// the next ready job, holds it while none is ready but some run, and
    /// stops it ("") when nothing is left.
    void schedule(Scheduler &scheduler, MPI_Comm comm, unsigned n_groups)
    {
      std::deque<int> waiting;
      unsigned        active = n_groups;
      while (active > 0)
        {
          int        flag = 0;
          MPI_Status status;
          MPI_Iprobe(MPI_ANY_SOURCE, tag_request, comm, &flag, &status);
          if (flag)
            {
              const std::string report = receive_string(comm, status);
              if (!report.empty())
                {
                  const auto r = nlohmann::json::parse(report);
                  scheduler.finish(status.MPI_SOURCE, r.at("ok").get<bool>(), r.at("reason").get<std::string>(),
                                   r.at("wall_s").get<double>());
                }
              waiting.push_back(status.MPI_SOURCE);
            }
          while (!waiting.empty())
            {
              if (const auto job = scheduler.next(waiting.front()))
                send_string(comm, waiting.front(), tag_job, job->to_text());
              else if (scheduler.n_running() == 0)
                {
                  send_string(comm, waiting.front(), tag_job, "");
                  --active;
                }
              else
                break;
              waiting.pop_front();
            }
          if (!flag)
            pause_briefly();
        }
    }

    /// A group's loop: its leader asks rank 0 for a job, the group runs it.
    void serve(const BatchSettings &bs, const std::vector<DesignCase> &designs, const Paths &paths, MPI_Comm sched,
               MPI_Comm group_comm)
    {
      const auto group  = stokes::MpiSession::on(group_comm);
      const bool leader = group.rank() == 0;
      std::string report;
      for (;;)
        {
          std::string text;
          if (leader)
            {
              send_string(sched, 0, tag_request, report);
              text = wait_for_string(sched, 0, tag_job);
            }
          text = broadcast_string(group_comm, text);
          if (text.empty())
            return;
          const Job   job = Job::from_text(text);
          const auto  t   = Clock::now();
          int         ok  = 1;
          std::string reason;
          try
            {
              run_job(job, bs, designs, paths, group);
            }
          catch (const std::exception &e)
            {
              ok     = 0;
              reason = e.what();
            }
          int all_ok = ok;
          MPI_Allreduce(&ok, &all_ok, 1, MPI_INT, MPI_MIN, group_comm);
          if (!all_ok && ok)
            reason = "failed on another process of its group";
          report = nlohmann::json{{"ok", all_ok != 0}, {"reason", reason}, {"wall_s", seconds_since(t)}}.dump();
        }
    }

    // ------------------------------------------------------------- the summary
    /// The designs' worst Goodman factor against key `k`, 1 marked: below
    /// it a reed does not survive its cycles.
    PlotPanel design_life_panel(const fs::path &data, const std::string &k, const std::string &label, double scale)
    {
      PlotPanel p{"Worst Goodman factor of the reeds (both sweeps): below 1 a reed does not survive", label,
                  "Goodman factor", false, true,
                  {{data, k, "worst_goodman_factor", "worst over the runs", "linespoints", scale, 1}}};
      p.levels.push_back({1.0, "survives above"});
      return p;
    }

    std::string axis_label(const std::string &key, double &scale)
    {
      scale = 1;
      if (key.size() > 2 && key.compare(key.size() - 2, 2, "_m") == 0)
        {
          scale = 1e3;
          return key + " [mm]";
        }
      return key;
    }

    /// Writes the table, its JSON and the plots; returns how many designs failed.
    std::size_t write_summary(const BatchSettings &bs, const std::vector<DesignCase> &designs, const Paths &paths)
    {
      const auto  failures = read_failures(paths);
      std::size_t n_failed = 0;
      const auto  keys     = design_keys(bs.designs);
      std::set<std::string> varying; // keys set to more than one value: the axes
      for (const auto &k : keys)
        {
          std::set<std::string> distinct;
          for (const auto &dc : designs)
            distinct.insert(dc.design.values().value(k, nlohmann::json()).dump());
          if (distinct.size() > 1)
            varying.insert(k);
        }
      const std::vector<std::string> numeric_columns = {
        "k_r_N_per_m", "f1_vacuum_Hz", "f1_oil_Hz", "m_r_eq321_kg", "R_10um_Pa_s_per_m3", "R_100um_Pa_s_per_m3",
        "A_eff_100um_m2", "map_openings", "bandwidth_Hz", "peak_velocity_m_per_s", "peak_velocity_frequency_Hz",
        "highest_velocity_m_per_s", "highest_velocity_frequency_Hz", "stored_pressure_low_Pa",
        "half_pressure_frequency_Hz", "velocity_valid_points", "pressure_valid_points", "worst_goodman_factor",
        "max_impact_velocity_m_per_s", "survives_to_Hz", "valid_to_Hz", "bandwidth_all_points_Hz",
        "peak_velocity_all_points_m_per_s"};
      std::ostringstream csv;
      csv << "design";
      for (const auto &k : keys)
        csv << "," << k;
      csv << ",status";
      for (const auto &c : numeric_columns)
        csv << "," << c;
      csv << ",map_set,reason\n";
      nlohmann::json rows = nlohmann::json::array();
      std::vector<std::string> plot_columns = {"index"};
      for (const auto &k : keys)
        plot_columns.push_back(k);
      for (const auto &c : numeric_columns)
        plot_columns.push_back(c);
      CsvTable plot_table(plot_columns);
      const double nan = std::nan("");
      struct Curve
      {
        fs::path    file;         ///< the map set's map-curve.csv
        std::string design, title; ///< the design's name; its name and varied values
      };
      std::vector<Curve> curves;
      for (std::size_t i = 0; i < designs.size(); ++i)
        {
          const auto       &dc = designs[i];
          const std::string h  = dc.map_set_hash;
          std::map<std::string, double> v;
          for (const auto &c : numeric_columns)
            v[c] = nan;
          std::string status = "ok", reason;
          const auto  add_failure = [&](const std::string &stage, const std::string &why) {
            status = "failed";
            reason += (reason.empty() ? "" : "; ") + stage + ": " + why;
          };
          for (const auto &f : failures)
            if (std::find(f.designs.begin(), f.designs.end(), dc.design.name) != f.designs.end())
              add_failure(f.job, f.reason);
          nlohmann::json row = {{"design", dc.design.name}, {"values", dc.design.values()}, {"map_set_hash", h}};
          if (paths.map_set_done(h))
            {
              const auto set = maps::MapSet::read(paths.cached(h));
              const auto link = paths.design(dc.design.name) / "map-set";
              std::error_code ec;
              if (fs::read_symlink(link, ec) != paths.cached(h))
                {
                  fs::remove(link, ec);
                  fs::create_directory_symlink(paths.cached(h), link);
                }
              if (set.reed())
                {
                  v["k_r_N_per_m"]  = set.reed()->stiffness_N_per_m;
                  v["f1_vacuum_Hz"] = set.reed()->frequency_Hz;
                  v["f1_oil_Hz"]    = set.reed()->frequency_in_fluid_Hz;
                  v["m_r_eq321_kg"] = set.reed()->effective_mass_eq321_kg;
                }
              const auto in_range = [&](double x) {
                return x >= dc.openings.from_m && x <= dc.openings.to_m;
              };
              if (in_range(10e-6))
                v["R_10um_Pa_s_per_m3"] = set.resistance().evaluate(10e-6).resistance;
              if (in_range(100e-6))
                {
                  v["R_100um_Pa_s_per_m3"] = set.resistance().evaluate(100e-6).resistance;
                  v["A_eff_100um_m2"]      = set.area().evaluate(100e-6).area;
                }
              v["map_openings"] = static_cast<double>(set.manifest().at("points").size());
              std::string title = dc.design.name;
              for (std::size_t e = 0; e < dc.design.entries.size(); ++e)
                if (varying.contains(dc.design.entries[e].table + "." + dc.design.entries[e].key))
                  title += " " + dc.design.entries[e].key + "=" + dc.design.text_values[e];
              curves.push_back({paths.cached(h) / "map-curve.csv", dc.design.name, title});
              row["map_set"] = paths.cached(h).string();
            }
          bool answered[2] = {false, false};
          for (const std::string kind : {"velocity", "pressure"})
            {
              // The answers the sweep job wrote (answer.json marks it finished).
              const auto dir = paths.design(dc.design.name) / kind;
              if (!fs::exists(dir / "answer.json"))
                continue;
              const auto a   = read_json_file(dir / "answer.json");
              const auto get = [&](const char *key) {
                return a.contains(key) && a[key].is_number() ? a[key].get<double>() : nan;
              };
              const char *const taken[][2] =
                {{"peak_velocity_m_per_s", "peak_velocity_m_per_s"},
                 {"peak_velocity_frequency_Hz", "peak_velocity_frequency_Hz"},
                 {"highest_velocity_m_per_s", "highest_velocity_m_per_s"},
                 {"highest_velocity_frequency_Hz", "highest_velocity_frequency_Hz"},
                 {"bandwidth_Hz", "first_reversal_Hz"},
                 {"bandwidth_all_points_Hz", "all_points_first_reversal_Hz"},
                 {"peak_velocity_all_points_m_per_s", "all_points_peak_velocity_m_per_s"},
                 {"survives_to_Hz", "survives_to_Hz"},
                 {"valid_to_Hz", "valid_to_Hz"}};
              if (kind == "velocity")
                for (const auto &[column, key] : taken)
                  v[column] = get(key);
              else
                {
                  v["stored_pressure_low_Pa"]     = get("low_frequency_pressure_Pa");
                  v["half_pressure_frequency_Hz"] = get("half_pressure_frequency_Hz");
                }
              // the design's worst over both sweeps
              const double g = get("worst_goodman_factor"), impact = get("max_impact_velocity_m_per_s");
              if (std::isfinite(g))
                v["worst_goodman_factor"] = std::isfinite(v["worst_goodman_factor"]) ? std::min(v["worst_goodman_factor"], g) : g;
              if (std::isfinite(impact))
                v["max_impact_velocity_m_per_s"] = std::isfinite(v["max_impact_velocity_m_per_s"]) ?
                                                     std::max(v["max_impact_velocity_m_per_s"], impact) : impact;
              v[kind + "_valid_points"]    = get("valid_points");
              answered[kind == "velocity" ? 0 : 1] = true;
              row[kind + "_points"]        = a.value("points", 0);
              row[kind + "_failed_points"] = a.value("failed_points", 0);
            }
          if (status == "ok" && (!paths.map_set_done(h) || !answered[0] || !answered[1]))
            add_failure("batch", "not finished");
          csv << dc.design.name;
          const auto values = dc.design.values();
          for (const auto &k : keys)
            {
              csv << ",";
              if (values.contains(k))
                csv << (values[k].is_number() ? exact(values[k].get<double>()) : values[k].get<std::string>());
            }
          csv << "," << status;
          std::vector<double> plot_row = {static_cast<double>(i + 1)};
          for (const auto &k : keys)
            plot_row.push_back(values.contains(k) && values[k].is_number() ? values[k].get<double>() : nan);
          for (const auto &c : numeric_columns)
            {
              csv << "," << (std::isfinite(v[c]) ? exact(v[c]) : "");
              row[c] = std::isfinite(v[c]) ? nlohmann::json(v[c]) : nlohmann::json(nullptr);
              plot_row.push_back(v[c]);
            }
          std::string quoted = reason;
          std::replace(quoted.begin(), quoted.end(), '"', '\'');
          std::replace(quoted.begin(), quoted.end(), '\n', ' ');
          csv << "," << h << ",\"" << quoted << "\"\n";
          row["status"] = status;
          row["reason"] = reason;
          n_failed += status != "ok";
          rows.push_back(row);
          plot_table.add_row(plot_row);
        }
      write_file_atomic(paths.out / "whatif.csv", csv.str());
      write_json(paths.out / "whatif.json",
                 {{"command", "whatif"},
                  {"rectify_version", RECTIFY_VERSION},
                  {"batch", bs.definition()},
                  {"columns",
                   {{"bandwidth_Hz", "the loaded sweep's first velocity reversal (linear between the points around it), "
                                     "from its valid runs only (system/validity.h: no reed beyond its map or stop, no "
                                     "pressure below cavitation, every reed's Goodman factor at least 1)"},
                    {"peak_velocity_m_per_s",
                     "the loaded sweep's largest mean output velocity below its first reversal (the usable band), at "
                     "peak_velocity_frequency_Hz; valid runs only"},
                    {"*_all_points_*", "the same from every run, valid or not: what the states hardware cannot reach would claim"},
                    {"worst_goodman_factor", "the smallest Goodman factor of either reed over every run of both sweeps"},
                    {"max_impact_velocity_m_per_s", "the fastest seat or stop impact of either reed over both sweeps"},
                    {"survives_to_Hz", "the loaded sweep's highest frequency up to which every run's Goodman factor is >= 1"},
                    {"valid_to_Hz", "the loaded sweep's highest frequency up to which every run is valid"},
                    {"highest_velocity_m_per_s", "the largest anywhere in the sweep (a band above a reversal can be higher)"},
                    {"half_pressure_frequency_Hz",
                     "the no-flow sweep's first frequency where the stored pressure has fallen to half of its value at "
                     "the lowest frequency (linear in log f)"},
                    {"k_r_N_per_m, f1_*, m_r_eq321_kg", "the reed from the map set's stiffness solve"},
                    {"R_*um, A_eff_100um_m2", "the map set's R(x) and A_eff(x) at 10 and 100 um tip opening"}}},
                  {"designs", rows}});

      // Plots (in plots/, beside their data): the answers against each
      // varied key, the family of R(x).
      const fs::path plots = paths.out / "plots";
      ensure_directory(plots);
      plot_table.write(plots / "designs.csv");
      const fs::path data = plots / "designs.csv";
      for (const auto &k : keys)
        {
          if (!varying.contains(k))
            continue;
          double            scale = 1;
          const std::string label = axis_label(k, scale);
          std::string       file  = k;
          std::replace(file.begin(), file.end(), '.', '-');
          render_plot(plots / ("whatif-" + file),
                      {{"Bandwidth: first velocity reversal (loaded) and half stored pressure (no flow)", label,
                        "frequency [Hz]", false, false,
                        {{data, k, "bandwidth_Hz", "first velocity reversal, loaded", "linespoints", scale, 1},
                         {data, k, "half_pressure_frequency_Hz", "stored pressure at half, no flow", "linespoints",
                          scale, 1},
                         {data, k, "peak_velocity_frequency_Hz", "peak velocity's frequency", "linespoints", scale, 1},
                         {data, k, "survives_to_Hz", "the reed survives (Goodman >= 1) up to", "linespoints", scale, 1},
                         {data, k, "bandwidth_all_points_Hz", "first reversal, every run (not valid ones too)",
                          "points pt 6", scale, 1}}},
                       {"Peak mean output velocity (loaded)", label, "velocity [mm/s]", false, false,
                        {{data, k, "peak_velocity_m_per_s", "below the first reversal", "linespoints", scale, 1e3},
                         {data, k, "highest_velocity_m_per_s", "anywhere in the sweep", "linespoints", scale, 1e3}}},
                       design_life_panel(data, k, label, scale),
                       {"Fastest impact at seat or stop (both sweeps)", label, "impact velocity [m/s]", false, false,
                        {{data, k, "max_impact_velocity_m_per_s", "either reed", "linespoints", scale, 1}}},
                       {"Reed stiffness k_r (FE)", label, "k_r [N/m]", true, true,
                        {{data, k, "k_r_N_per_m", "k_r", "linespoints", scale, 1}}},
                       {"Reed's first mode (FE)", label, "f1 [Hz]", true, true,
                        {{data, k, "f1_vacuum_Hz", "in vacuum", "linespoints", scale, 1},
                         {data, k, "f1_oil_Hz", "in oil (eq. 3.20's added mass)", "linespoints", scale, 1}}}});
        }
      if (!curves.empty())
        {
          std::vector<PlotSeries> r, a;
          for (const auto &[file, design, title] : curves)
            {
              const fs::path copy = plots / ("map-curve-" + design + ".csv");
              write_file_atomic(copy, read_text(file));
              r.push_back({copy, "opening_m", "R_Pa_s_per_m3", title, "lines", 1e6, 1});
              a.push_back({copy, "opening_m", "A_eff_m2", title, "lines", 1e6, 1e6});
            }
          render_plot(plots / "resistance-family",
                      {{"R(x) of every design (map sets)", "tip opening [um]", "R [Pa s/m^3]", true, true, r},
                       {"A_eff(x) of every design", "tip opening [um]", "A_eff [mm^2]", true, false, a}});
        }
      return n_failed;
    }
  } // namespace

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
