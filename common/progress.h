// Progress of long runs on stderr: a line per finished item with an estimate
// of the time left. Thread-safe.
#pragma once

#include <chrono>
#include <mutex>
#include <string>

namespace rectify
{
  class Progress
  {
  public:
    Progress(std::string label, std::size_t n_total, std::size_t n_done_already = 0,
             bool quiet = false);
    /// One item finished; `what` describes it ("1200 Hz: 0.41 s").
    void step(const std::string &what);
    /// One item found finished (a checkpoint): counted, not printed, and not
    /// in the time estimate.
    void skip();
    /// `more` items were added to the run (adaptive runs learn their size as they go).
    void extend(std::size_t more);

  private:
    std::mutex                            mutex_;
    std::string                           label_;
    std::size_t                           n_total_;
    std::size_t                           n_done_;
    std::size_t                           n_done_at_start_;
    bool                                  quiet_;
    std::chrono::steady_clock::time_point start_;
  };
} // namespace rectify
