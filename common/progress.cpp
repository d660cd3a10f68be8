#include "common/progress.h"

#include <cstdio>

namespace rectify
{
  Progress::Progress(std::string label, std::size_t n_total, std::size_t n_done_already,
                     bool quiet)
    : label_(std::move(label))
    , n_total_(n_total)
    , n_done_(n_done_already)
    , n_done_at_start_(n_done_already)
    , quiet_(quiet)
    , start_(std::chrono::steady_clock::now())
  {
    if (!quiet_ && n_done_already > 0)
      std::fprintf(stderr, "%s: resuming, %zu of %zu already done\n", label_.c_str(),
                   n_done_already, n_total_);
  }

  void Progress::step(const std::string &what)
  {
    std::lock_guard<std::mutex> lock(mutex_);
    ++n_done_;
    if (quiet_)
      return;
    const double elapsed =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
    const double per_item = elapsed / static_cast<double>(n_done_ - n_done_at_start_);
    const double left     = per_item * static_cast<double>(n_total_ > n_done_ ? n_total_ - n_done_ : 0);
    std::fprintf(stderr, "%s [%zu/%zu] %s  (elapsed %.1f s, about %.0f s left)\n",
                 label_.c_str(), n_done_, n_total_, what.c_str(), elapsed, left);
    std::fflush(stderr);
  }
  void Progress::skip()
  {
    std::lock_guard<std::mutex> lock(mutex_);
    ++n_done_;
    ++n_done_at_start_;
  }

  void Progress::extend(std::size_t more)
  {
    std::lock_guard<std::mutex> lock(mutex_);
    n_total_ += more;
  }
} // namespace rectify
