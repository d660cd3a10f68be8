#include "whatif/scheduler.h"

#include <algorithm>
#include <cstdio>
#include <stdexcept>

#include "common/io.h"

namespace rectify::whatif
{
  namespace fs = std::filesystem;

  Scheduler::Scheduler(const std::vector<DesignCase> &designs, const Paths &paths, unsigned n_groups)
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

  std::optional<Job> Scheduler::next(int leader)
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

  void Scheduler::finish(int leader, bool ok, const std::string &reason, double wall_s)
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

  std::optional<Job> Scheduler::set_job(SetState &s, const std::string &hash)
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

  Job Scheduler::dispatch(const Job &job, int leader)
  {
    running_[leader] = job;
    log("start " + job.id(designs_) + " rank " + std::to_string(leader));
    return job;
  }

  std::string Scheduler::format_fixed(double v, int digits)
  {
    char buf[64];
    std::snprintf(buf, sizeof(buf), "%.*f", digits, v);
    return buf;
  }

  void Scheduler::log(const std::string &line)
  {
    log_ << utc_now() << " " << line << "\n";
    log_.flush();
  }

  double Scheduler::jobs_left() const
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

  void Scheduler::progress(const Job &job, int leader, bool ok, double wall_s, const std::string &reason)
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
} // namespace rectify::whatif
