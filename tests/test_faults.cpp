// Faults (issue 16, docs/reliability.md): a long command killed with
// SIGKILL at random moments and started again with the same command ends with
// the files an uninterrupted run writes (timings and resumed counts aside),
// and no half-written file is ever visible in between; a disk that fills or
// a folder that turns read-only mid-run gives a clear error and keeps what
// was finished; two processes on one --out: the second refuses.
//
// The kill moments are drawn at random (the seed is in the failure message):
// every CI run tries other moments. FaultsSlow.* repeat this on the design
// command and with more kills.
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include <algorithm>
#include <chrono>
#include <csignal>
#include <fcntl.h>
#include <filesystem>
#include <fstream>
#include <random>
#include <regex>
#include <sstream>
#include <string>
#include <sys/wait.h>
#include <thread>
#include <unistd.h>
#include <vector>

#include "cli_helpers.h"
#include "common/checkpoint.h"
#include "common/io.h"
#include "common/output_lock.h"

using namespace rectify;
using namespace rectify::test_support;
namespace fs = std::filesystem;

namespace
{
  std::string slurp(const fs::path &file)
  {
    std::ifstream in(file, std::ios::binary);
    return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
  }

  /// Starts `rectify ARGS` (output to `log`) with extra environment
  /// variables; returns its pid (the rectify process itself: sh execs it).
  pid_t spawn(const std::string &args, const fs::path &log, const std::vector<std::string> &env = {})
  {
    std::string command;
    for (const auto &e : env)
      command += e + " ";
    command += "exec " + std::string(RECTIFY_BINARY) + " " + args + " >> '" + log.string() + "' 2>&1";
    const pid_t pid = ::fork();
    if (pid == 0)
      {
        ::execl("/bin/sh", "sh", "-c", command.c_str(), static_cast<char *>(nullptr));
        ::_exit(127);
      }
    return pid;
  }

  /// Waits up to `ms` for `pid`; kills it with SIGKILL if still running.
  /// True if it had finished by itself (its exit code in `exit_code`).
  bool wait_or_kill(pid_t pid, double ms, int &exit_code)
  {
    const auto end = std::chrono::steady_clock::now() + std::chrono::microseconds(static_cast<long>(1000 * ms));
    int        status = 0;
    while (std::chrono::steady_clock::now() < end)
      {
        if (::waitpid(pid, &status, WNOHANG) == pid)
          {
            exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
            return true;
          }
        std::this_thread::sleep_for(std::chrono::milliseconds(5));
      }
    ::kill(pid, SIGKILL);
    ::waitpid(pid, &status, 0);
    exit_code = -1;
    return false;
  }

  int run_to_end(pid_t pid)
  {
    int status = 0;
    ::waitpid(pid, &status, 0);
    return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  }

  bool is_timing_or_resume_key(const std::string &key)
  {
    return key.find("time_s") != std::string::npos || key.find("time_per") != std::string::npos ||
           key.find("resumed") != std::string::npos || key == "created";
  }

  /// A text (report, VTU) with its dates, wall times, resumed counts and
  /// Markdown "wall [s]" and "loading [s]" (a time) columns replaced by placeholders.
  std::string mask_timings(const std::string &text)
  {
    std::string out = std::regex_replace(text, std::regex(R"(\d{4}-\d\d-\d\dT\d\d:\d\d:\d\dZ)"), "DATE");
    // deal.II's VTU header: "0:40:09 at 2026/12/1", neither the hour nor the
    // month and day padded to two digits
    out = std::regex_replace(out, std::regex(R"(\d{1,2}:\d\d:\d\d at \d{4}/\d{1,2}/\d{1,2})"), "DATE");
    out = std::regex_replace(out, std::regex(R"([0-9.]+ s wall)"), "T s wall");
    out = std::regex_replace(out, std::regex(R"(\d+ from a checkpoint)"), "N from a checkpoint");
    std::istringstream in(out);
    std::string        masked;
    long               wall_column = -1;
    for (std::string line; std::getline(in, line);)
      {
        if (line.empty() || line[0] != '|')
          wall_column = -1;
        else
          {
            std::vector<std::string> cells;
            std::stringstream        s(line.substr(1));
            for (std::string c; std::getline(s, c, '|');)
              cells.push_back(c);
            for (std::size_t i = 0; i < cells.size(); ++i)
              if (cells[i].find("wall [s]") != std::string::npos || cells[i].find("loading [s]") != std::string::npos)
                wall_column = static_cast<long>(i);
            if (wall_column >= 0 && static_cast<std::size_t>(wall_column) < cells.size() &&
                cells[wall_column].find("[s]") == std::string::npos)
              cells[wall_column] = "T";
            line = "|";
            for (const auto &c : cells)
              line += c + "|";
          }
        masked += line + "\n";
      }
    return masked;
  }

  std::vector<std::string> relative_files(const fs::path &dir)
  {
    std::vector<std::string> files;
    for (const auto &e : fs::recursive_directory_iterator(dir))
      if (e.is_regular_file())
        files.push_back(fs::relative(e.path(), dir).string());
    std::sort(files.begin(), files.end());
    return files;
  }

  /// The two folders hold the same result: the same files, each the same
  /// apart from timings and resumed counts.
  void expect_same_result(const fs::path &expected, const fs::path &actual)
  {
    const auto files = relative_files(expected);
    ASSERT_EQ(relative_files(actual), files);
    for (const auto &f : files)
      {
        const std::string a = slurp(expected / f), b = slurp(actual / f);
        const std::string ext = fs::path(f).extension().string();
        if (ext == ".json")
          {
            auto ja = nlohmann::json::parse(a), jb = nlohmann::json::parse(b);
            erase_keys(ja, is_timing_or_resume_key);
            erase_keys(jb, is_timing_or_resume_key);
            EXPECT_EQ(ja, jb) << f;
          }
        else if (ext == ".csv")
          {
            const bool any_order = f.find("-partial.csv") != std::string::npos ||
                                   f.find("-states.csv") != std::string::npos;
            EXPECT_EQ(csv_without_columns(a, is_timing_or_resume_key, any_order),
                      csv_without_columns(b, is_timing_or_resume_key, any_order))
              << f;
          }
        else if (ext == ".md" || ext == ".vtu")
          EXPECT_EQ(mask_timings(a), mask_timings(b)) << f;
        else
          EXPECT_TRUE(a == b) << f << " differs";
      }
  }

  /// Every file a reader can see is whole: JSON parses, CSV and SVG end
  /// where they should, PNG ends with its IEND chunk. Temporaries (named as
  /// such: x.tmp.PID, x.part) may be there; the next run removes them.
  void expect_nothing_half_written(const fs::path &dir)
  {
    if (!fs::exists(dir))
      return;
    for (const auto &e : fs::recursive_directory_iterator(dir))
      {
        if (!e.is_regular_file() || is_leftover_temporary(e.path().filename().string()))
          continue;
        const std::string text = slurp(e.path());
        const std::string ext  = e.path().extension().string();
        bool whole = true;
        if (ext == ".json")
          whole = nlohmann::json::accept(text);
        else if (ext == ".csv" || ext == ".gp" || ext == ".md" || ext == ".toml")
          whole = !text.empty() && text.back() == '\n';
        else if (ext == ".svg")
          whole = text.rfind("</svg>") != std::string::npos;
        else if (ext == ".png")
          whole = text.size() > 12 && text.compare(text.size() - 8, 4, "IEND") == 0;
        EXPECT_TRUE(whole) << e.path() << " is not whole";
      }
  }

  struct KillReport
  {
    std::size_t n_killed = 0;
    int         exit_code = -1;
  };

  /// Runs `args --out OUT` until it finishes, killing it with SIGKILL at
  /// `n_kills` random moments within `span_ms` of each start, checking the
  /// folder after every kill. The seed goes into every failure message.
  KillReport kill_and_resume(const std::string &args, const fs::path &out, std::size_t n_kills, double span_ms)
  {
    const unsigned seed = std::random_device{}();
    SCOPED_TRACE("kill moments drawn with seed " + std::to_string(seed));
    std::mt19937                           rng(seed);
    std::uniform_real_distribution<double> moment(0.02 * span_ms, span_ms);
    const fs::path                         log = out.string() + ".log";
    KillReport                             report;
    for (std::size_t k = 0; k < n_kills; ++k)
      {
        const double ms  = moment(rng);
        const pid_t  pid = spawn(args + " --out " + out.string(), log);
        int          code = 0;
        if (wait_or_kill(pid, ms, code))
          {
            report.exit_code = code;
            return report; // finished before the kill
          }
        ++report.n_killed;
        expect_nothing_half_written(out);
      }
    report.exit_code = run_to_end(spawn(args + " --out " + out.string(), log));
    if (report.exit_code != 0)
      ADD_FAILURE() << slurp(log);
    return report;
  }

  const std::string coarse_flow = "[mesh]\nsize_reed_m = 0.5e-3\nsize_far_m = 1.5e-3\nstation_spacing_m = 0.4e-3\n"
                                  "gap_layers = 2\nreed_layers = 1\nabove_layers = 1\nport_layer_m = 1e-3\n"
                                  "[flow]\nsolver = \"iterative\"\n";
  const std::string coarse_reed = "[stiffness]\ncells_along_length = 8\ncells_across_width = 6\n"
                                  "cells_through_thickness = 1\nn_modes = 1\n";
  const std::string sweep_args  = "sweep --scenario loaded --from 100 --to 1000 --n 8 --cycles 40 --jobs 2 --quiet";
} // namespace

namespace
{
  /// `args` (with `case_text` as --case if not empty) run whole into
  /// DIR/whole and killed `n_kills` times at random moments within
  /// `span_ms` into DIR/killed: the same result in the end.
  void expect_kills_change_nothing(const std::string &name, const std::string &case_text, std::string args,
                                   std::size_t n_kills, double span_ms)
  {
    const auto dir = scratch(name);
    if (!case_text.empty())
      {
        write_file_atomic(dir / "case.toml", case_text);
        args += " --case " + (dir / "case.toml").string();
      }
    const auto whole = rectify_cli(args + " --out " + (dir / "whole").string());
    ASSERT_EQ(whole.exit_code, 0) << whole.output;
    const auto report = kill_and_resume(args, dir / "killed", n_kills, span_ms);
    ASSERT_EQ(report.exit_code, 0);
    ::testing::Test::RecordProperty("kills", static_cast<int>(report.n_killed));
    expect_same_result(dir / "whole", dir / "killed");
  }
} // namespace

TEST(Faults, AKilledSweepResumesToTheUninterruptedFiles)
{
  expect_kills_change_nothing("faults_sweep", "", sweep_args, 4, 3000);
}

TEST(Faults, AKilledStiffnessMapResumesToTheUninterruptedFiles)
{
  expect_kills_change_nothing("faults_stiffness", coarse_reed, "map-stiffness --thickness 0.1e-3:0.2e-3:5", 4, 3000);
}

TEST(Faults, AKilledResistanceMapResumesToTheUninterruptedFiles)
{
  expect_kills_change_nothing("faults_resistance", coarse_flow, "map-resistance --openings 10e-6:500e-6:3", 2, 20000);
}

TEST(Faults, TheSecondProcessOnAnOutputFolderRefuses)
{
  const auto     dir = scratch("faults_lock");
  const fs::path out = dir / "out";
  // A long sweep holds the folder; a second sweep, a simulate and a
  // map-stiffness into it are refused before any work, naming the holder.
  const std::string long_sweep = "sweep --scenario loaded --from 100 --to 1000 --n 8 --cycles 200 --jobs 1 --quiet";
  const pid_t       first      = spawn(long_sweep + " --out " + out.string(), dir / "first.log");
  for (int i = 0; i < 400 && !fs::exists(out / "sweep-partial.json"); ++i)
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  ASSERT_TRUE(fs::exists(out / "sweep-partial.json")) << slurp(dir / "first.log");
  for (const std::string &second :
       {long_sweep, std::string("simulate --scenario no-flow --frequency 100 --cycles 2"),
        std::string("map-stiffness --thickness 0.1e-3:0.2e-3:2")})
    {
      const auto r = rectify_cli(second + " --out " + out.string());
      EXPECT_EQ(r.exit_code, 2) << second << "\n" << r.output;
      EXPECT_NE(r.output.find("is in use by another process (pid " + std::to_string(first)), std::string::npos)
        << r.output;
    }
  EXPECT_FALSE(fs::exists(out / "timeseries.csv"));
  EXPECT_FALSE(fs::exists(out / "map-partial.csv"));
  // The first is not disturbed; once it is gone (here: killed), the folder is free.
  int code = 0;
  EXPECT_FALSE(wait_or_kill(first, 100, code)) << "the long sweep ended early: " << slurp(dir / "first.log");
  const auto r = rectify_cli("simulate --scenario no-flow --frequency 100 --cycles 2 --out " + out.string());
  EXPECT_EQ(r.exit_code, 0) << r.output;
}

namespace
{
  struct DiskFault
  {
    const char *kind;
    const char *message;
  };

  /// `args --out OUT` with the folder's disk failing after `n_writes`
  /// writes: exit 1 naming a file and the system's reason; what was written
  /// is whole; the same command afterwards (disk fine) finishes with the
  /// uninterrupted run's files.
  void expect_fault_is_survived(const std::string &args, const fs::path &whole, const fs::path &out,
                                const DiskFault &fault, int n_writes)
  {
    SCOPED_TRACE(std::string(fault.kind) + " after " + std::to_string(n_writes) + " writes");
    fs::create_directories(out);
    const fs::path log = out.string() + ".log";
    const pid_t    pid = spawn(args + " --out " + out.string(), log,
                               {"LD_PRELOAD=" RECTIFY_FAULT_SHIM, "RECTIFY_FAULT_DIR=" + fs::absolute(out).string(),
                                "RECTIFY_FAULT_AFTER=" + std::to_string(n_writes),
                                std::string("RECTIFY_FAULT_ERRNO=") + fault.kind});
    const int code = run_to_end(pid);
    const auto text = slurp(log);
    EXPECT_EQ(code, 1) << text;
    EXPECT_NE(text.find(fault.message), std::string::npos) << text;
    EXPECT_NE(text.find("cannot "), std::string::npos) << text;
    expect_nothing_half_written(out);
    fs::remove(log);
    const auto again = rectify_cli(args + " --out " + out.string());
    ASSERT_EQ(again.exit_code, 0) << again.output;
    expect_same_result(whole, out);
  }
} // namespace

TEST(Faults, AFullDiskOrAReadOnlyFolderMidSweepLosesNothingFinished)
{
  const auto dir = scratch("faults_disk");
  ASSERT_EQ(rectify_cli(sweep_args + " --out " + (dir / "whole").string()).exit_code, 0);
  // Writes into the folder: the probe, the checkpoint's settings and
  // header, then one row per finished run (24), then the results.
  for (const int n : {6, 12, 30})
    {
      expect_fault_is_survived(sweep_args, dir / "whole", dir / ("enospc" + std::to_string(n)),
                               {"ENOSPC", "No space left on device"}, n);
      expect_fault_is_survived(sweep_args, dir / "whole", dir / ("erofs" + std::to_string(n)),
                               {"EROFS", "Read-only file system"}, n);
    }
  // The checkpoint kept the rows finished before the disk filled.
  const auto resumed = nlohmann::json::parse(slurp(dir / "enospc12" / "summary.json"));
  EXPECT_EQ(resumed["runs_resumed"].get<int>(), 8); // writes 4-11; the 12th was cut
}

TEST(Faults, AFullDiskMidStiffnessMapLosesNothingFinished)
{
  const auto dir = scratch("faults_disk_stiffness");
  write_file_atomic(dir / "coarse.toml", coarse_reed);
  const std::string args = "map-stiffness --case " + (dir / "coarse.toml").string() + " --thickness 0.1e-3:0.2e-3:5";
  ASSERT_EQ(rectify_cli(args + " --out " + (dir / "whole").string()).exit_code, 0);
  expect_fault_is_survived(args, dir / "whole", dir / "enospc", {"ENOSPC", "No space left on device"}, 6);
  expect_fault_is_survived(args, dir / "whole", dir / "erofs", {"EROFS", "Read-only file system"}, 6);
}

TEST(Faults, ACheckpointRowCutOffIsDroppedNotJoinedToTheNext)
{
  // The row a kill or a full disk cut off goes when the checkpoint is
  // reopened; before, the next row was appended to its end.
  const auto dir = scratch("faults_checkpoint");
  {
    Checkpoint c(dir, "x", {{"a", 1}}, "p,q");
    c.append("1,2");
  }
  {
    std::ofstream cut(dir / "x.csv", std::ios::app);
    cut << "3,4"; // no line end
  }
  {
    Checkpoint c(dir, "x", {{"a", 1}}, "p,q");
    ASSERT_EQ(c.finished_rows(), std::vector<std::string>{"1,2"});
    c.append("5,6");
  }
  EXPECT_EQ(slurp(dir / "x.csv"), "p,q\n1,2\n5,6\n");
}

TEST(Faults, ACheckpointOfOtherColumnsIsRefusedNotReadAsThese)
{
  const auto dir = scratch("faults_checkpoint_columns");
  {
    Checkpoint c(dir, "x", {{"a", 1}}, "p,q");
    c.append("1,2");
  }
  try
    {
      Checkpoint c(dir, "x", {{"a", 1}}, "p,q,r");
      FAIL() << "a checkpoint of other columns was opened";
    }
  catch (const InputError &e)
    {
      EXPECT_NE(std::string(e.what()).find("other columns"), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find("x.csv"), std::string::npos) << e.what();
    }
  EXPECT_EQ(slurp(dir / "x.csv"), "p,q\n1,2\n"); // left as it was
}

TEST(Faults, TheLockRemovesWhatAKilledRunLeftHalfWritten)
{
  const auto dir = scratch("faults_leftovers");
  fs::create_directories(dir / "out" / "sub");
  for (const char *f : {"summary.json.tmp.123", "sub/a.csv.tmp.9", "plot.png.part", ".rectify-write-test-77"})
    write_file_atomic(dir / "out" / f, "half");
  for (const char *f : {"keep.csv", "notes.tmp.txt", "x.tmp.12a"})
    write_file_atomic(dir / "out" / f, "whole\n");
  OutputLock lock;
  lock.acquire(dir / "out");
  EXPECT_EQ(lock.n_removed_leftovers(), 4u);
  EXPECT_EQ(relative_files(dir / "out"), (std::vector<std::string>{"keep.csv", "notes.tmp.txt", "x.tmp.12a"}));
  OutputLock same;
  EXPECT_THROW(same.acquire(dir / "out"), InputError); // the same process, another holder: refused too
}

TEST(FaultsSlow, AKilledDesignResumesToTheUninterruptedFiles)
{
  expect_kills_change_nothing("faults_design",
                              coarse_flow + coarse_reed +
                                "[design]\nopenings_from_m = 10e-6\nopenings_to_m = 300e-6\ninitial_openings = 3\n"
                                "tolerance = 0.02\n",
                              "design", 6, 40000);
}

TEST(FaultsSlow, ASweepKilledTwentyTimesResumesToTheUninterruptedFiles)
{
  expect_kills_change_nothing("faults_sweep_many", "", sweep_args, 20, 2500);
}
