// The batch's jobs (a part of `rectify whatif`, batch.h): per map set the
// reed's stiffness solve, one Stokes solve per tip opening, the map set's
// assembly; per design the loaded velocity sweep and the no-flow
// stored-pressure sweep. run_job runs one on its group of ranks and leaves
// its result as a file (paths.h).
#pragma once

#include <string>
#include <vector>

#include "stokes_solver/stokes.h"
#include "whatif/batch.h"
#include "whatif/paths.h"

namespace rectify::whatif
{
  namespace fs = std::filesystem;

  enum class JobKind
  {
    reed,
    opening,
    map_set,
    velocity,
    pressure
  };

  /// "reed", "opening", "map-set", "velocity", "pressure"
  const char *kind_name(JobKind k);

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

  /// Runs `job` on the ranks of `group` (its root writes the result).
  void run_job(const Job &job, const BatchSettings &bs, const std::vector<DesignCase> &designs, const Paths &paths,
               const stokes::MpiSession &group);
} // namespace rectify::whatif
