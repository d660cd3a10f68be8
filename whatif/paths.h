// The batch's files (a part of `rectify whatif`, batch.h): where each job's
// result lies, how a finished opening and a failure are recorded, and how a
// finished map set moves into the cache. Every job's result is a file written
// atomically: the queue is rebuilt from these when a batch starts.
#pragma once

#include <chrono>
#include <filesystem>
#include <map>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "stokes_solver/resistance_sweep.h"

namespace rectify::whatif
{
  namespace fs = std::filesystem;

  using Clock = std::chrono::steady_clock;
  inline double seconds_since(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }

  /// A double to the last digit (a job's opening in its id and file name).
  std::string exact(double x);
  std::string read_text(const fs::path &path);
  nlohmann::json read_json_file(const fs::path &path);

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

  /// The columns of an opening's record.
  std::string openings_header();

  /// One opening's record (an opening job's result).
  stokes::OpeningPoint read_opening(const fs::path &file);

  /// The openings solved so far for a map set in the making.
  std::map<double, stokes::OpeningPoint> read_openings(const fs::path &work);

  /// A failed job's record (failures/JOB.json).
  struct Failure
  {
    std::string              job, reason;
    std::vector<std::string> designs;
  };

  /// Every failure recorded in the batch's folder, by file name.
  std::vector<Failure> read_failures(const Paths &paths);

  /// Moves a finished map set from the batch's work folder into the cache.
  void publish(const fs::path &from, const fs::path &to);
} // namespace rectify::whatif
