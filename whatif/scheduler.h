// The batch's queue (a part of `rectify whatif`, batch.h): the state of
// every job and the next ready one. It lives on rank 0 and is used by the
// scheduler thread alone (transport.h); it knows nothing of MPI. Built from
// the files (paths.h), so a restarted batch takes up exactly what is left;
// a failed job is recorded (failures/JOB.json) and steered around: its map
// set's other jobs and its designs' sweeps are not dispatched.
#pragma once

#include <fstream>
#include <map>
#include <optional>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include "whatif/batch.h"
#include "whatif/jobs.h"
#include "whatif/paths.h"

namespace rectify::whatif
{
  namespace fs = std::filesystem;

  class Scheduler
  {
  public:
    /// `n_groups`: the groups of ranks that run jobs (for the ETA).
    Scheduler(const std::vector<DesignCase> &designs, const Paths &paths, unsigned n_groups);

    /// The next ready job (marked running on `leader`), or nothing.
    std::optional<Job> next(int leader);

    /// The job `leader` ran has ended (ok, or failed for `reason`).
    void finish(int leader, bool ok, const std::string &reason, double wall_s);

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

    std::optional<Job> set_job(SetState &s, const std::string &hash);
    Job                dispatch(const Job &job, int leader);
    static std::string format_fixed(double v, int digits);
    void               log(const std::string &line);
    /// Jobs left, estimated: a map set in the making needs as many
    /// openings as those finished in this batch did (else 4x its coarse grid).
    double             jobs_left() const;
    void               progress(const Job &job, int leader, bool ok, double wall_s, const std::string &reason);

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
} // namespace rectify::whatif
