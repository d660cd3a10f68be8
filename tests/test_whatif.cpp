// `rectify whatif` (whatif/): the designs of a batch, the system's answers
// read off a sweep, and batches of a coarse valve on MPI: one and two
// processes agree (one rank per job, and two ranks per Stokes solve), a
// cached map set is not made again, a batch killed at a
// random moment and started again ends as an uninterrupted one with no job
// finished twice, a second batch on the same folder is refused, a failing
// design is reported while the others complete, and bad input is refused
// before any job runs.
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <map>
#include <random>
#include <set>
#include <signal.h>
#include <thread>

#include "common/io.h"
#include "common/output_lock.h"
#include "tests/cli_helpers.h"
#include "whatif/batch.h"
#include "whatif/designs.h"

using namespace rectify;
using namespace rectify::test_support;
namespace fs = std::filesystem;

namespace
{
  // The coarse valve at 5 % interpolation tolerance, and short sweeps.
  const std::string coarse_case = coarse_valve_case("0.05");
  const std::string short_sweeps = " --velocity-sweep 200:3400:5 --pressure-sweep 2:1000:4 --cycles 5 ";

  std::string read_file(const fs::path &p)
  {
    std::ifstream     in(p);
    std::stringstream s;
    s << in.rdbuf();
    return s.str();
  }

  /// whatif.csv as rows of cells, by design.
  std::map<std::string, std::vector<std::string>> table(const fs::path &out)
  {
    std::map<std::string, std::vector<std::string>> rows;
    std::stringstream                               in(read_file(out / "whatif.csv"));
    std::string                                     line;
    std::getline(in, line);
    while (std::getline(in, line))
      {
        std::vector<std::string> cells;
        std::stringstream        l(line);
        for (std::string c; std::getline(l, c, ',');)
          cells.push_back(c);
        rows[cells.at(0)] = cells;
      }
    return rows;
  }

  /// Every file under `dir` (relative paths), but the run's own records.
  std::set<std::string> files(const fs::path &dir)
  {
    std::set<std::string> names;
    for (const auto &e : fs::recursive_directory_iterator(dir))
      {
        const auto rel = e.path().lexically_relative(dir).string(); // a map-set link as itself
        if (rel != "jobs.log" && rel != "run.json")
          names.insert(rel);
      }
    return names;
  }

  int run(const std::string &command, const fs::path &log)
  {
    const int status = std::system((command + " > " + log.string() + " 2>&1").c_str());
    return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  }

  /// Two tables equal: the same designs and cells, numbers to `tolerance`
  /// (relative); with `fe_only`, the map sets' numbers alone (the reed, R,
  /// A_eff, openings), not the sweeps' answers.
  void expect_same_table(const fs::path &a, const fs::path &b, double tolerance, bool fe_only = false)
  {
    std::vector<std::string> header;
    {
      std::stringstream in(read_file(a / "whatif.csv"));
      std::string       line;
      std::getline(in, line);
      std::stringstream l(line);
      for (std::string c; std::getline(l, c, ',');)
        header.push_back(c);
    }
    const std::set<std::string> answers = {"bandwidth_Hz", "peak_velocity_m_per_s", "peak_velocity_frequency_Hz",
                                           "highest_velocity_m_per_s", "highest_velocity_frequency_Hz",
                                           "stored_pressure_low_Pa", "half_pressure_frequency_Hz",
                                           "velocity_valid_points", "pressure_valid_points", "worst_goodman_factor",
                                           "max_impact_velocity_m_per_s", "survives_to_Hz", "valid_to_Hz",
                                           "bandwidth_all_points_Hz", "peak_velocity_all_points_m_per_s"};
    const auto ta = table(a), tb = table(b);
    ASSERT_EQ(ta.size(), tb.size());
    for (const auto &[name, row] : ta)
      {
        ASSERT_TRUE(tb.contains(name)) << name;
        const auto &other = tb.at(name);
        ASSERT_EQ(row.size(), other.size()) << name;
        for (std::size_t c = 0; c < row.size(); ++c)
          {
            if (fe_only && c < header.size() && answers.contains(header[c]))
              continue;
            char      *end = nullptr;
            const double x = std::strtod(row[c].c_str(), &end);
            if (!row[c].empty() && *end == '\0' && std::isfinite(x) && x != 0)
              EXPECT_NEAR(std::strtod(other[c].c_str(), nullptr) / x, 1.0, tolerance) << name << " column " << c;
            else
              EXPECT_EQ(row[c], other[c]) << name << " column " << c;
          }
      }
  }
} // namespace

TEST(Whatif, GridsTablesAndRangesAreReadAndMalformedOnesRefused)
{
  const auto v = whatif::parse_variation("geometry.reed_thickness_m=0.08e-3:0.25e-3:10");
  EXPECT_EQ(v.table, "geometry");
  EXPECT_EQ(v.key, "reed_thickness_m");
  ASSERT_EQ(v.values.size(), 10u);
  EXPECT_EQ(v.values.front(), 0.08e-3);
  EXPECT_EQ(v.values.back(), 0.25e-3);
  EXPECT_NEAR(v.values[1], 0.08e-3 + 0.17e-3 / 9, 1e-15);
  const auto lg = whatif::parse_variation("geometry.port_diameter_m=1e-3:4e-3:3:log");
  EXPECT_NEAR(lg.values[1], 2e-3, 1e-15);
  EXPECT_EQ(whatif::parse_variation("load.mass_kg=5:5:1").values, std::vector<double>{5.0});
  for (const char *bad : {"geometry.reed_thickness_m", "reed_thickness_m=1:2:3", "geometry.t=2:1:3",
                          "geometry.t=1:2:0", "geometry.t=1:2:-1", "geometry.t=1:2:2.5", "geometry.t=1:nan:3",
                          "geometry.t=1:2", "geometry.t=1:2:1", "geometry.t=0:2:3:log"})
    EXPECT_THROW(whatif::parse_variation(bad), InputError) << bad;

  // A grid: the product, the first key varying slowest.
  const auto grid = whatif::grid_designs({whatif::parse_variation("geometry.reed_thickness_m=1e-4:2e-4:2"),
                                          whatif::parse_variation("geometry.port_diameter_m=2e-3:3e-3:3")});
  ASSERT_EQ(grid.size(), 6u);
  EXPECT_EQ(grid[0].name, "d01");
  EXPECT_EQ(grid[5].name, "d06");
  EXPECT_EQ(grid[1].values()["geometry.reed_thickness_m"], 1e-4);
  EXPECT_EQ(grid[1].values()["geometry.port_diameter_m"], 2.5e-3);
  EXPECT_EQ(grid[3].values()["geometry.reed_thickness_m"], 2e-4);
  EXPECT_THROW(whatif::grid_designs({whatif::parse_variation("load.mass_kg=1:2:2"),
                                     whatif::parse_variation("load.mass_kg=1:3:2")}),
               InputError);

  // A table.
  const auto dir = scratch("whatif_tables");
  write_file_atomic(dir / "ok.csv", "# designs\nname,geometry.reed_thickness_m,valves.model\nthin,1e-4,dynamic\n"
                                    "thick,2e-4,ideal\n");
  const auto t = whatif::read_designs_table(dir / "ok.csv");
  ASSERT_EQ(t.size(), 2u);
  EXPECT_EQ(t[1].name, "thick");
  EXPECT_EQ(t[1].entries[0].value, "2e-4");
  EXPECT_EQ(t[1].entries[1].value, "\"ideal\"");
  const std::map<std::string, std::string> bad = {
    {"missing.csv", ""},
    {"empty.csv", "# nothing\n"},
    {"nokey.csv", "name\na\n"},
    {"badkey.csv", "reed_thickness_m\n1e-4\n"},
    {"norows.csv", "geometry.reed_thickness_m\n"},
    {"short.csv", "geometry.reed_thickness_m,geometry.port_diameter_m\n1e-4\n"},
    {"emptycell.csv", "geometry.reed_thickness_m,geometry.port_diameter_m\n1e-4,\n"},
    {"twice.csv", "name,geometry.reed_thickness_m\na,1e-4\na,2e-4\n"},
    {"dupcol.csv", "geometry.reed_thickness_m,geometry.reed_thickness_m\n1,2\n"}};
  for (const auto &[name, text] : bad)
    {
      if (name != "missing.csv")
        write_file_atomic(dir / name, text);
      try
        {
          (void)whatif::read_designs_table(dir / name);
          ADD_FAILURE() << name << " was accepted";
        }
      catch (const InputError &e)
        {
          EXPECT_NE(std::string(e.what()).find(name), std::string::npos) << e.what(); // names the file
        }
    }
  fs::remove_all(dir);
}

TEST(Whatif, AnswersAreReadOffTheSweepsExactly)
{
  // Velocity v = 1 - f / 1000 beyond a peak at 400 Hz: the reversal at 1000 Hz
  // lies between samples and is found exactly (v is linear there); a higher
  // band above it (2 m/s at 2500 Hz) is the sweep's highest, not its peak.
  std::vector<double> f, v;
  for (double x = 100; x <= 3000; x += 150)
    {
      f.push_back(x);
      v.push_back(x <= 400 ? x / 400.0 * 0.6 : x < 2000 ? 1.0 - x / 1000.0 : x == 2500 ? 2.0 : 0.5);
    }
  const auto a = whatif::velocity_answer(f, v);
  EXPECT_DOUBLE_EQ(a.peak_velocity_m_per_s, 0.6);
  EXPECT_DOUBLE_EQ(a.peak_frequency_Hz, 400);
  EXPECT_NEAR(a.first_reversal_Hz, 1000, 1e-9);
  EXPECT_DOUBLE_EQ(a.highest_velocity_m_per_s, 2.0);
  EXPECT_DOUBLE_EQ(a.highest_frequency_Hz, 2500);
  EXPECT_TRUE(std::isnan(whatif::velocity_answer({1, 2}, {1, 2}).first_reversal_Hz));
  // Pressure p = p0 / (1 + (f / fc)^2)... linear in log f between samples:
  // p = p0 (1 - log(f / 10) / log(100)) halves at f = 100 exactly.
  std::vector<double> fp, p;
  for (double x = 10; x <= 2000; x *= 1.7)
    {
      fp.push_back(x);
      p.push_back(1e6 * std::max(0.01, 1 - std::log(x / 10) / std::log(100.0) * 1.0));
    }
  p[0] = 1e6;
  const auto b = whatif::pressure_answer(fp, p);
  EXPECT_DOUBLE_EQ(b.low_frequency_pressure_Pa, 1e6);
  EXPECT_NEAR(b.half_pressure_frequency_Hz, 100, 1e-9);
}

TEST(Whatif, AnswersComeFromTheValidRunsAndTheDesignsLifeFromEveryRun)
{
  // Five runs: valid at 100 and 200 Hz, a reed that would not survive at
  // 300 Hz (Goodman 0.6, the fastest impact), a failed run at 400 Hz, valid
  // again at 500 Hz but beyond its map at 600 Hz. The answers see 100, 200
  // and 500 Hz; the worst Goodman factor and impact every finished run.
  std::vector<system::SweepPoint> points;
  const auto point = [&](double f, double v, double goodman, double impact, bool valid, bool failed = false) {
    system::SweepPoint p{"dynamic", f, 0.0, v, true, 0.0, failed ? "failed: CVODE" : "periodic", 0, 50, 0, 0, 0, 0, 0, 0, 0};
    p.goodman_factor          = goodman;
    p.goodman_below_1         = goodman < 1;
    p.max_seat_impact_m_per_s = impact;
    p.valid                   = valid;
    p.beyond_map              = !valid && goodman >= 1;
    if (failed)
      p.mean_velocity_m_per_s = std::nan("");
    points.push_back(p);
  };
  point(100, 0.10, 3.0, 0.5, true);
  point(200, 0.30, 1.5, 1.0, true);
  point(300, 0.90, 0.6, 4.0, false);
  point(400, 0.0, 1.0, 0.0, false, true);
  point(500, -0.20, 1.2, 2.0, true);
  point(600, 0.50, 1.1, 1.0, false);
  const auto d = whatif::sweep_verdict(points, true);
  EXPECT_EQ(d.points, 6u);
  EXPECT_EQ(d.failed_points, 1u);
  EXPECT_EQ(d.valid_points, 3u);
  EXPECT_EQ(d.valid_frequencies_Hz, (std::vector<double>{100, 200, 500}));
  EXPECT_DOUBLE_EQ(d.worst_goodman_factor, 0.6);
  EXPECT_DOUBLE_EQ(d.max_impact_velocity_m_per_s, 4.0);
  EXPECT_DOUBLE_EQ(d.survives_to_Hz, 200);
  EXPECT_DOUBLE_EQ(d.valid_to_Hz, 200);
  const auto valid = whatif::velocity_answer(d.valid_frequencies_Hz, d.valid_values);
  EXPECT_DOUBLE_EQ(valid.peak_velocity_m_per_s, 0.30); // not the 0.90 of the reed that breaks
  EXPECT_NEAR(valid.first_reversal_Hz, 200 + 300 * 0.3 / 0.5, 1e-12);
  const auto all = whatif::velocity_answer(d.frequencies_Hz, d.values);
  EXPECT_DOUBLE_EQ(all.peak_velocity_m_per_s, 0.90);
  // no run survives: nothing to answer with
  points.erase(points.begin(), points.begin() + 2);
  EXPECT_TRUE(std::isnan(whatif::sweep_verdict(points, true).survives_to_Hz));
}

TEST(Whatif, BadInputIsRefusedBeforeAnyJobRuns)
{
  const auto dir = scratch("whatif_bad");
  write_file_atomic(dir / "coarse.toml", coarse_case);
  write_file_atomic(dir / "unknown.csv", "geometry.reed_thicknes_m\n1e-4\n");
  write_file_atomic(dir / "uncovered.csv", "name,geometry.port_diameter_m\nwide,6e-3\n");
  const std::string base = "whatif --case " + (dir / "coarse.toml").string() + " --cache " + (dir / "cache").string() +
                           " --out " + (dir / "out").string() + " ";
  const std::vector<std::pair<std::string, std::string>> cases = {
    {"--vary geometry.reed_thicknes_m=1e-4:2e-4:2", "reed_thicknes_m"},
    {"--vary geometry.reed_thickness_m=1e-4:2e-4:0", "N = 0"},
    {"--vary geometry.reed_thickness_m=2e-4:1e-4:2", "above TO"},
    {"--vary geometry.reed_thickness_m=-1e-4:1e-4:2", "reed_thickness_m"},
    {"--designs " + (dir / "unknown.csv").string(), "reed_thicknes_m"},
    {"--designs " + (dir / "uncovered.csv").string(), "cover"},
    {"--vary geometry.reed_thickness_m=1e-4:2e-4:2 --velocity-sweep 10:5:3", "--velocity-sweep"},
    {"", "no designs"}};
  for (const auto &[args, expected] : cases)
    {
      const auto r = rectify_cli(base + args);
      EXPECT_EQ(r.exit_code, 2) << args << "\n" << r.output;
      EXPECT_NE(r.output.find(expected), std::string::npos) << args << "\n" << r.output;
      EXPECT_FALSE(fs::exists(dir / "out" / "batch.json")) << args; // no job ran
    }
  // Procs per job that do not divide the processes.
  const int status = run(mpirun(2) + RECTIFY_BINARY + " " + base + "--vary geometry.reed_thickness_m=1e-4:2e-4:2 "
                                                                  "--procs-per-job 3",
                         dir / "ppj.log");
  EXPECT_NE(status, 0);
  EXPECT_NE(read_file(dir / "ppj.log").find("--procs-per-job 3"), std::string::npos) << read_file(dir / "ppj.log");
  EXPECT_FALSE(fs::exists(dir / "out" / "batch.json"));
  fs::remove_all(dir);
}

TEST(Whatif, OneAndTwoProcessesAgreeCachedMapSetsAreReusedAndAKilledBatchResumes)
{
  const auto dir = scratch("whatif_batch");
  write_file_atomic(dir / "coarse.toml", coarse_case);
  // Three designs, two map sets: d03 differs from d01 in its load alone.
  write_file_atomic(dir / "designs.csv", "name,geometry.reed_thickness_m,load.mass_kg\n"
                                         "d01,0.127e-3,22.68\nd02,0.2e-3,22.68\nd03,0.127e-3,10\n");
  const auto command = [&](int np, const std::string &out, const std::string &cache) {
    return mpirun(np) + RECTIFY_BINARY + " whatif --case " + (dir / "coarse.toml").string() + " --designs " +
           (dir / "designs.csv").string() + short_sweeps + "--cache " + (dir / cache).string() + " --out " +
           (dir / out).string();
  };
  ASSERT_EQ(run(command(1, "one", "cache1"), dir / "one.log"), 0) << read_file(dir / "one.log");
  ASSERT_EQ(run(command(2, "two", "cache2"), dir / "two.log"), 0) << read_file(dir / "two.log");

  // The table: every design finished, physics in the right direction.
  const auto rows = table(dir / "one");
  ASSERT_EQ(rows.size(), 3u);
  const auto header = [&]() {
    std::stringstream        in(read_file(dir / "one" / "whatif.csv"));
    std::string              line;
    std::getline(in, line);
    std::vector<std::string> h;
    std::stringstream        l(line);
    for (std::string c; std::getline(l, c, ',');)
      h.push_back(c);
    return h;
  }();
  const auto col = [&](const std::string &name) {
    return static_cast<std::size_t>(std::find(header.begin(), header.end(), name) - header.begin());
  };
  for (const auto &[name, row] : rows)
    EXPECT_EQ(row.at(col("status")), "ok") << name << ": " << row.back();
  const auto num = [&](const std::string &design, const std::string &c) { return std::stod(rows.at(design).at(col(c))); };
  // k_r ~ t^3 (coarse reed: within 3 %), f1 ~ t.
  EXPECT_NEAR(num("d02", "k_r_N_per_m") / num("d01", "k_r_N_per_m"), std::pow(0.2 / 0.127, 3), 0.03 * std::pow(0.2 / 0.127, 3));
  EXPECT_NEAR(num("d02", "f1_vacuum_Hz") / num("d01", "f1_vacuum_Hz"), 0.2 / 0.127, 0.03 * 0.2 / 0.127);
  EXPECT_EQ(rows.at("d01").at(col("map_set")), rows.at("d03").at(col("map_set"))); // one map set, shared
  EXPECT_NE(rows.at("d01").at(col("map_set")), rows.at("d02").at(col("map_set")));
  EXPECT_EQ(num("d01", "k_r_N_per_m"), num("d03", "k_r_N_per_m"));
  EXPECT_GT(num("d01", "peak_velocity_all_points_m_per_s"), 0);
  // Annealed 304 (the case's) does not survive the loaded sweep's cycles at
  // 200-3400 Hz: no valid run, so no valid answer, and the reason in the table
  EXPECT_LT(num("d01", "worst_goodman_factor"), 1.0);
  EXPECT_GT(num("d01", "max_impact_velocity_m_per_s"), 0.0);
  if (num("d01", "velocity_valid_points") == 0)
    {
      EXPECT_EQ(rows.at("d01").at(col("peak_velocity_m_per_s")), "");
    }
  EXPECT_TRUE(fs::exists(dir / "one" / "plots" / "whatif-geometry-reed_thickness_m.png"));
  EXPECT_TRUE(fs::exists(dir / "one" / "plots" / "resistance-family.png"));
  EXPECT_TRUE(fs::is_symlink(dir / "one" / "designs" / "d01" / "map-set"));
  const auto one_log = read_file(dir / "one" / "jobs.log");
  EXPECT_NE(one_log.find("2 map sets (0 found finished in the cache)"), std::string::npos) << one_log;

  // -np 1 and -np 2: the same table (FE numbers to 1e-9).
  expect_same_table(dir / "one", dir / "two", 1e-9);
  EXPECT_EQ(files(dir / "one"), files(dir / "two"));
  // Each Stokes solve on a sub-communicator of two ranks (one group): the
  // same map sets to 1e-8 (the direct solver: the partition changes only the
  // rounding, which the thin gaps' conditioning lifts to about 1e-9: 1.05e-9
  // in R at 10 um on one run). Not the sweeps' answers: maps that differ by 1e-12 move the
  // loaded sweep's non-periodic points by their own scatter (1e-6-1e-3 here;
  // docs/benchmarks.md), so only equal maps give equal answers (above).
  ASSERT_EQ(run(command(2, "pairs", "cache4") + " --procs-per-job 2", dir / "pairs.log"), 0)
    << read_file(dir / "pairs.log");
  expect_same_table(dir / "one", dir / "pairs", 1e-8, true);
  EXPECT_EQ(nlohmann::json::parse(read_file(dir / "pairs" / "run.json"))["procs_per_job"], 2);

  // A cached design is not recomputed: another batch on the same cache runs no FE job.
  ASSERT_EQ(run(command(2, "again", "cache1"), dir / "again.log"), 0) << read_file(dir / "again.log");
  const auto again = read_file(dir / "again" / "jobs.log");
  EXPECT_NE(again.find("2 map sets (2 found finished in the cache)"), std::string::npos) << again;
  for (const char *fe : {"start reed:", "start opening:", "start map-set:"})
    EXPECT_EQ(again.find(fe), std::string::npos) << fe << "\n" << again;
  expect_same_table(dir / "one", dir / "again", 0);

  // A batch on a folder another process holds (the lock a running batch
  // takes, held here so that the test does not depend on which of two
  // processes starts first): refused, nothing written.
  {
    OutputLock held;
    held.acquire(dir / "held");
    const int second = run(command(1, "held", "cache3"), dir / "second.log");
    EXPECT_NE(second, 0) << read_file(dir / "second.log");
    EXPECT_NE(read_file(dir / "second.log").find("in use"), std::string::npos) << read_file(dir / "second.log");
    EXPECT_FALSE(fs::exists(dir / "held" / "batch.json"));
  }

  // Killed (kill -9, the whole process group) at a random moment, started
  // again. The moment is counted in the batch's own finished jobs, not in
  // seconds: after a random number of them (none to all but one) and, while
  // three or more are left, a random part of a second into the next. So it
  // falls before the batch ends however the machine's load changes (a kill
  // timed in seconds came after the end once, when other tests' load lifted).
  // each job's "done" lines in a batch's log (none while it has no log)
  const auto done_in = [](const fs::path &log) {
    std::map<std::string, int> done;
    std::stringstream          in(fs::exists(log) ? read_file(log) : std::string());
    for (std::string line; std::getline(in, line);)
      if (const auto at = line.find(" done "); at != std::string::npos)
        ++done[line.substr(at + 6, line.find(' ', at + 6) - at - 6)];
    return done;
  };
  const auto jobs_done = [&](const fs::path &log) {
    int n = 0;
    for (const auto &[job, times] : done_in(log))
      n += times;
    return n;
  };
  const int total = jobs_done(dir / "two" / "jobs.log");
  ASSERT_GE(total, 3) << read_file(dir / "two" / "jobs.log");
  std::random_device device;
  const unsigned     seed = device();
  std::mt19937       rng(seed);
  const int          kill_at  = std::uniform_int_distribution<int>(0, total - 1)(rng);
  const int          extra_ms = kill_at <= total - 3 ? std::uniform_int_distribution<int>(0, 500)(rng) : 0;
  const std::string when = "killed after " + std::to_string(kill_at) + " of " + std::to_string(total) + " jobs and " +
                           std::to_string(extra_ms) + " ms (seed " + std::to_string(seed) + ")";
  SCOPED_TRACE(when);
  std::cout << when << std::endl;
  write_file_atomic(dir / "killed.sh", command(2, "killed", "cache3") + " > " + (dir / "killed-1.log").string() + " 2>&1\n");
  std::system(("setsid bash " + (dir / "killed.sh").string() + " & echo $! > " + (dir / "pid").string()).c_str());
  const pid_t leader  = static_cast<pid_t>(std::stol(read_file(dir / "pid")));
  const auto  started = std::chrono::steady_clock::now();
  while (jobs_done(dir / "killed" / "jobs.log") < kill_at && ::kill(leader, 0) == 0 &&
         std::chrono::steady_clock::now() < started + std::chrono::minutes(20))
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  std::this_thread::sleep_for(std::chrono::milliseconds(extra_ms));
  std::system(("kill -9 -" + std::to_string(leader) + " 2>/dev/null").c_str());
  for (int i = 0; i < 100 && std::system(("pgrep -f " + (dir / "killed").string() + " > /dev/null").c_str()) == 0; ++i)
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  // neither ended nor timed out before its moment
  ASSERT_GE(jobs_done(dir / "killed" / "jobs.log"), kill_at) << read_file(dir / "killed-1.log");
  ASSERT_FALSE(fs::exists(dir / "killed" / "whatif.csv")) << "the batch ended before it was killed";
  ASSERT_EQ(run(command(2, "killed", "cache3"), dir / "killed-2.log"), 0) << read_file(dir / "killed-2.log");
  expect_same_table(dir / "two", dir / "killed", 1e-9);
  EXPECT_EQ(files(dir / "two"), files(dir / "killed"));
  // No job finished twice.
  const auto done = done_in(dir / "killed" / "jobs.log");
  EXPECT_FALSE(done.empty());
  for (const auto &[job, n] : done)
    EXPECT_EQ(n, 1) << job;
  fs::remove_all(dir);
}

TEST(Whatif, AFailingDesignIsReportedAndTheOthersComplete)
{
  const auto dir = scratch("whatif_failing");
  write_file_atomic(dir / "coarse.toml", coarse_case);
  // The second design's Stokes solver stops after one iteration: its openings fail.
  write_file_atomic(dir / "designs.csv", "name,geometry.reed_thickness_m,flow.solver,flow.max_iterations\n"
                                         "good,0.127e-3,direct,1000\nstuck,0.15e-3,iterative,1\n");
  const auto status = run(mpirun(2) + RECTIFY_BINARY + " whatif --case " + (dir / "coarse.toml").string() +
                            " --designs " + (dir / "designs.csv").string() + short_sweeps + "--cache " +
                            (dir / "cache").string() + " --out " + (dir / "out").string(),
                          dir / "out.log");
  ASSERT_EQ(status, 0) << read_file(dir / "out.log");
  const auto summary = nlohmann::json::parse(read_file(dir / "out" / "whatif.json"));
  ASSERT_EQ(summary["designs"].size(), 2u);
  const auto &good = summary["designs"][0], &stuck = summary["designs"][1];
  EXPECT_EQ(good["status"], "ok") << good.dump(1);
  EXPECT_GT(good["peak_velocity_all_points_m_per_s"].get<double>(), 0);
  EXPECT_TRUE(good["worst_goodman_factor"].is_number()) << good.dump(1);
  EXPECT_EQ(stuck["status"], "failed");
  const std::string reason = stuck["reason"];
  EXPECT_NE(reason.find("opening:"), std::string::npos) << reason; // the job ...
  EXPECT_NE(reason.find("converge"), std::string::npos) << reason; // ... and why
  EXPECT_TRUE(fs::exists(dir / "out" / "failures"));
  EXPECT_NE(read_file(dir / "out.log").find("1 failed"), std::string::npos) << read_file(dir / "out.log");
  fs::remove_all(dir);
}
