// The what-if batch's queue (whatif/scheduler.h) without MPI: jobs handed out
// in their order, each once, failures steered around, a restart taking up
// only what is left. Each job's result is the file the real job would leave
// (whatif/paths.h), written here by the test.
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <map>
#include <set>
#include <string>
#include <vector>

#include "common/io.h"
#include "whatif/scheduler.h"

namespace fs = std::filesystem;
using namespace rectify;
using namespace rectify::whatif;

namespace
{
  /// Three designs: two share the map set "H1", one has "H2".
  std::vector<DesignCase> three_designs()
  {
    std::vector<DesignCase> designs;
    for (const auto &[name, hash] : std::vector<std::pair<std::string, std::string>>{{"d01", "H1"}, {"d02", "H1"},
                                                                                      {"d03", "H2"}})
      {
        DesignCase dc{Design{name, {}, {}}, CaseFile::parse("", name + ".toml"), "", hash, {}};
        dc.openings.from_m            = 2e-6;
        dc.openings.to_m              = 200e-6;
        dc.openings.initial_openings  = 4;
        dc.openings.tolerance         = 5e-3;
        designs.push_back(dc);
      }
    return designs;
  }

  /// What the job leaves behind when it ends well: lubrication's R ~ x^-3
  /// and a slowly growing A_eff for an opening.
  void leave_result(const Job &job, const std::vector<DesignCase> &designs, const Paths &paths)
  {
    switch (job.kind)
      {
        case JobKind::reed:
          ensure_directory(paths.work(job.hash) / "reed");
          write_file_atomic(paths.work(job.hash) / "reed" / "reed.json", "{}");
          return;
        case JobKind::opening:
          {
            stokes::OpeningPoint p;
            p.opening_m     = job.x;
            p.R_Pa_s_per_m3 = 1e12 * std::pow(1e-5 / job.x, 3) + 1e9;
            p.A_eff_m2      = 1e-6 * (1 + std::log(job.x / 1e-6));
            ensure_directory(paths.work(job.hash) / "openings");
            write_file_atomic(Paths::opening_file(paths.work(job.hash), job.x),
                              openings_header() + "\n" + csv_row(p.row()) + "\n");
            return;
          }
        case JobKind::map_set:
          ensure_directory(paths.cached(job.hash));
          write_file_atomic(paths.cached(job.hash) / "manifest.json", "{}");
          return;
        case JobKind::velocity:
        case JobKind::pressure:
          {
            const auto dir = paths.design(designs[job.design].design.name) /
                             (job.kind == JobKind::velocity ? "velocity" : "pressure");
            ensure_directory(dir);
            write_file_atomic(dir / "answer.json", "{}");
            return;
          }
      }
  }

  struct Folder
  {
    fs::path root;
    Paths    paths;
    explicit Folder(const std::string &name)
      : root(fs::temp_directory_path() / ("rectify-scheduler-" + name + "-" + std::to_string(::getpid())))
      , paths{root / "out", root / "cache"}
    {
      fs::remove_all(root);
      ensure_directory(paths.out);
    }
    ~Folder() { fs::remove_all(root); }
  };

  /// Runs the queue on two leaders until it is empty or `stop_after` jobs
  /// have ended; `fails` (job ids) end badly. Returns the ids in the order
  /// they were handed out; `ended` (if given) gets those that ended.
  std::vector<std::string> drain(Scheduler &s, const std::vector<DesignCase> &designs, const Paths &paths,
                                 const std::set<std::string> &fails = {}, std::size_t stop_after = 1000,
                                 std::vector<std::string> *ended_ids = nullptr)
  {
    std::vector<std::string> order;
    std::map<int, Job>       running;
    for (std::size_t ended = 0; ended < stop_after;)
      {
        for (int leader : {0, 1})
          if (!running.contains(leader))
            if (const auto job = s.next(leader))
              {
                for (const auto &[other, r] : running) // never two of one job, nor a map set beside its openings
                  {
                    EXPECT_NE(r.id(designs), job->id(designs));
                    if (job->kind == JobKind::map_set)
                      {
                        EXPECT_FALSE(r.kind == JobKind::opening && r.hash == job->hash) << r.id(designs);
                      }
                  }
                running[leader] = *job;
                order.push_back(job->id(designs));
              }
        if (running.empty())
          break;
        // the two leaders end their jobs in turn (one a job, the other the next)
        const auto it            = running.size() > 1 && ended % 2 ? std::next(running.begin()) : running.begin();
        const auto [leader, job] = *it;
        const bool ok            = !fails.contains(job.id(designs));
        if (ok)
          leave_result(job, designs, paths);
        s.finish(leader, ok, ok ? "" : "injected failure", 1.0);
        if (ended_ids)
          ended_ids->push_back(job.id(designs));
        running.erase(leader);
        ++ended;
      }
    return order;
  }

  std::size_t position(const std::vector<std::string> &order, const std::string &id)
  {
    for (std::size_t i = 0; i < order.size(); ++i)
      if (order[i] == id)
        return i;
    return order.size();
  }
} // namespace

TEST(WhatIfScheduler, EveryJobOnceInItsOrderAndASharedMapSetMadeOnce)
{
  Folder      f("order");
  const auto  designs = three_designs();
  Scheduler   s(designs, f.paths, 2);
  const auto  order = drain(s, designs, f.paths);
  EXPECT_EQ(std::set<std::string>(order.begin(), order.end()).size(), order.size()) << "a job handed out twice";
  for (const std::string h : {"H1", "H2"})
    {
      const auto reed = position(order, "reed:" + h), map_set = position(order, "map-set:" + h);
      ASSERT_LT(reed, order.size()) << h;
      ASSERT_LT(map_set, order.size()) << h;
      std::size_t openings = 0;
      for (std::size_t i = 0; i < order.size(); ++i)
        if (order[i].rfind("opening:" + h + ":", 0) == 0)
          {
            ++openings;
            EXPECT_GT(i, reed) << order[i] << " before its reed";
            EXPECT_LT(i, map_set) << order[i] << " after its map set";
          }
      EXPECT_GE(openings, 4u) << h << ": at least the coarse grid";
      EXPECT_TRUE(f.paths.map_set_done(h));
    }
  for (const std::string d : {"d01", "d02", "d03"})
    for (const std::string kind : {"velocity:", "pressure:"})
      {
        const auto at = position(order, kind + d);
        ASSERT_LT(at, order.size()) << kind << d;
        EXPECT_GT(at, position(order, std::string("map-set:") + (d == "d03" ? "H2" : "H1")));
      }
  EXPECT_EQ(s.report.n_map_sets, 2u);
  EXPECT_EQ(s.report.n_jobs_run, order.size());
  EXPECT_EQ(s.report.n_jobs_failed, 0u);
  EXPECT_FALSE(s.next(0).has_value());
  EXPECT_EQ(s.n_running(), 0u);
}

TEST(WhatIfScheduler, AFailedReedIsRecordedAndItsMapSetAndDesignsSteeredAround)
{
  Folder      f("failure");
  const auto  designs = three_designs();
  Scheduler   s(designs, f.paths, 2);
  const auto  order = drain(s, designs, f.paths, {"reed:H2"});
  for (const auto &id : order)
    {
      EXPECT_NE(id.rfind("opening:H2:", 0), 0u) << id;
      EXPECT_NE(id, "map-set:H2");
      EXPECT_NE(id, "velocity:d03");
      EXPECT_NE(id, "pressure:d03");
    }
  EXPECT_LT(position(order, "velocity:d02"), order.size()) << "the other map set's designs still run";
  EXPECT_EQ(s.report.n_jobs_failed, 1u);
  const auto failures = read_failures(f.paths);
  ASSERT_EQ(failures.size(), 1u);
  EXPECT_EQ(failures[0].job, "reed:H2");
  EXPECT_EQ(failures[0].reason, "injected failure");
  EXPECT_EQ(failures[0].designs, std::vector<std::string>{"d03"});
  // a new batch over the same folder knows the failure and does not retry it
  Scheduler again(designs, f.paths, 2);
  EXPECT_FALSE(again.next(0).has_value());
}

TEST(WhatIfScheduler, ARestartedQueueHandsOutOnlyWhatIsLeft)
{
  const auto designs = three_designs();
  Folder     g("whole");
  Scheduler  whole(designs, g.paths, 2);
  const auto all = drain(whole, designs, g.paths);
  // killed after 5 jobs ended (in H1's openings), and after most of them
  // (a map set already in the cache when it starts again)
  for (const std::size_t cut : {std::size_t{5}, all.size() - 4})
    {
      Folder                   f("restart-" + std::to_string(cut));
      std::vector<std::string> ended;
      {
        Scheduler  s(designs, f.paths, 2);
        const auto handed = drain(s, designs, f.paths, {}, cut, &ended);
        ASSERT_GT(handed.size(), ended.size()) << "one was still running";
      }
      Scheduler  s(designs, f.paths, 2);
      const auto rest = drain(s, designs, f.paths);
      // the map sets finished before the restart are found in the cache
      const auto cached = static_cast<std::size_t>(std::count_if(
        ended.begin(), ended.end(), [](const std::string &id) { return id.rfind("map-set:", 0) == 0; }));
      EXPECT_EQ(s.report.n_map_sets_cached, cached);
      if (cut > 5)
        {
          EXPECT_GE(cached, 1u) << "the late cut comes after a map set";
        }
      // those that ended are not handed out again, the one running when it
      // stopped is: together every job of an uninterrupted batch, each once
      ASSERT_EQ(ended.size(), cut);
      std::set<std::string> done(ended.begin(), ended.end());
      for (const auto &id : rest)
        EXPECT_FALSE(done.contains(id)) << id << " ran again";
      std::set<std::string> together(rest.begin(), rest.end());
      together.insert(done.begin(), done.end());
      EXPECT_EQ(together, std::set<std::string>(all.begin(), all.end())) << "cut after " << cut;
      EXPECT_EQ(rest.size() + cut, all.size()) << "cut after " << cut;
    }
}

TEST(WhatIfScheduler, AFailedOpeningStopsItsMapSetAndIsNotRetriedOnRestart)
{
  Folder     f("opening");
  const auto designs = three_designs();
  std::string opening; // H2's first opening, whatever its plan makes it
  {
    Folder     g("opening-probe");
    Scheduler  s(designs, g.paths, 2);
    for (const auto &id : drain(s, designs, g.paths))
      if (opening.empty() && id.rfind("opening:H2:", 0) == 0)
        opening = id;
  }
  ASSERT_FALSE(opening.empty());
  Scheduler  s(designs, f.paths, 2);
  const auto order = drain(s, designs, f.paths, {opening});
  EXPECT_EQ(position(order, "map-set:H2"), order.size());
  EXPECT_EQ(position(order, "velocity:d03"), order.size());
  EXPECT_LT(position(order, "pressure:d01"), order.size());
  Scheduler again(designs, f.paths, 2);
  EXPECT_FALSE(again.next(0).has_value()) << "the failed opening's map set is not taken up again";
}

TEST(WhatIfScheduler, TwoLeadersNeverGetTheSameJob)
{
  Folder     f("leaders");
  const auto designs = three_designs();
  Scheduler  s(designs, f.paths, 2);
  const auto a = s.next(0), b = s.next(1);
  ASSERT_TRUE(a && b);
  EXPECT_NE(a->id(designs), b->id(designs));
  EXPECT_EQ(a->id(designs), "reed:H1");
  EXPECT_EQ(b->id(designs), "reed:H2"); // H1's openings wait for its reed
  EXPECT_FALSE(s.next(2).has_value()) << "nothing is ready while both reeds run";
  EXPECT_EQ(s.n_running(), 2u);
  // H1's reed done: its openings, a different one to each leader that asks
  ensure_directory(f.paths.work("H1") / "reed");
  write_file_atomic(f.paths.work("H1") / "reed" / "reed.json", "{}");
  s.finish(0, true, "", 1.0);
  const auto c = s.next(0), d = s.next(2);
  ASSERT_TRUE(c && d);
  EXPECT_EQ(c->kind, JobKind::opening);
  EXPECT_EQ(d->kind, JobKind::opening);
  EXPECT_NE(c->x, d->x);
}
