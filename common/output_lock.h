// One process at a time per output folder. A command holds an exclusive
// advisory lock (flock) on its --out folder while it writes there; a second
// process on the same folder is refused with the holder's pid and command
// instead of mixing its files with the first's. The lock is on the folder
// itself, so it leaves no file behind, and the kernel drops it when its holder
// exits in any way (kill -9 included): there are no stale locks to clean.
//
// Whoever holds the lock also knows that no one else is writing there, so it
// removes what a killed run left half-written: the temporaries of
// write_file_atomic ("NAME.tmp.PID"), of plots ("NAME.png.part") and of the
// writability probe. Checkpoint rows cut off by a kill are dropped by the
// Checkpoint that reopens them.
#pragma once

#include <filesystem>
#include <string>

namespace rectify
{
  class OutputLock
  {
  public:
    OutputLock() = default;
    ~OutputLock();
    OutputLock(OutputLock &&other) noexcept;
    OutputLock &operator=(OutputLock &&other) noexcept;
    OutputLock(const OutputLock &)            = delete;
    OutputLock &operator=(const OutputLock &) = delete;

    /// Creates `dir` (and parents) if needed and locks it. Throws InputError
    /// naming the folder and the process holding it if another process does.
    /// No-op if this object already holds `dir`.
    void acquire(const std::filesystem::path &dir);

    /// Locks `dir` only if it exists already: a command whose folder appears
    /// only with its results calls this at start (so that a folder in use is
    /// refused before any work) and acquire() when it writes.
    void acquire_if_exists(const std::filesystem::path &dir);

    bool held() const { return fd_ >= 0; }
    /// Number of leftover temporaries removed when the lock was taken.
    std::size_t n_removed_leftovers() const { return n_removed_; }

  private:
    int                   fd_ = -1;
    std::filesystem::path dir_;
    std::size_t           n_removed_ = 0;
  };

  /// True for the names of temporaries a killed rectify process can leave
  /// ("x.csv.tmp.1234", "x.png.part", ".rectify-write-test-1234").
  bool is_leftover_temporary(const std::string &file_name);
} // namespace rectify
