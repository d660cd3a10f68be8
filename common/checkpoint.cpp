#include "common/checkpoint.h"

#include <cerrno>
#include <cstring>
#include <fcntl.h>
#include <fstream>
#include <sys/stat.h>
#include <unistd.h>

#include "common/case_file.h"
#include "common/io.h"

namespace rectify
{
  bool Checkpoint::holds_other(const std::filesystem::path &dir, const std::string &name,
                               const nlohmann::json &fingerprint)
  {
    if (!std::filesystem::exists(dir / (name + ".csv")))
      return false;
    nlohmann::json old;
    try
      {
        std::ifstream in(dir / (name + ".json"));
        old = nlohmann::json::parse(in);
      }
    catch (const std::exception &)
      {
        old = nullptr;
      }
    return old != fingerprint;
  }

  Checkpoint::Checkpoint(const std::filesystem::path &dir, const std::string &name,
                         const nlohmann::json &fingerprint, const std::string &header)
  {
    const auto csv  = dir / (name + ".csv");
    const auto json = dir / (name + ".json");
    if (std::filesystem::exists(csv))
      {
        if (holds_other(dir, name, fingerprint))
          throw InputError("'" + dir.string() + "' holds a partial run with other settings (" +
                           json.string() + "); choose another --out, or delete its " + name +
                           ".* files");
        std::ifstream in(csv);
        std::string   line, kept = header + "\n";
        bool          first = true, cut = false;
        while (std::getline(in, line))
          {
            const bool complete = !in.eof(); // a last line without newline was cut off
            if (first)
              {
                first = false;
                // Another version's columns (same settings) cannot be resumed:
                // its rows would be read as these columns.
                if (line != header)
                  throw InputError("'" + csv.string() + "' holds a partial run with other columns (written by " +
                                   "another version of rectify?); choose another --out, or delete its " + name +
                                   ".* files");
                continue;
              }
            if (complete && !line.empty())
              {
                rows_.push_back(line);
                kept += line + "\n";
              }
            else if (!complete && !line.empty())
              cut = true;
          }
        // A row cut off by a kill (or a full disk) goes, else the next row
        // would be appended to its end.
        if (cut)
          write_file_atomic(csv, kept);
      }
    else
      {
        write_json(json, fingerprint);
        write_file_atomic(csv, header + "\n");
      }
    path_ = csv;
    fd_   = ::open(csv.c_str(), O_WRONLY | O_APPEND | O_CLOEXEC);
    if (fd_ < 0)
      throw std::runtime_error("cannot append to '" + csv.string() + "': " + std::strerror(errno));
  }

  Checkpoint::~Checkpoint()
  {
    if (fd_ >= 0)
      ::close(fd_);
  }

  void Checkpoint::append(const std::string &row)
  {
    std::lock_guard<std::mutex> lock(mutex_);
    const std::string           line = row + "\n";
    // One write per row: a kill leaves the row whole or cut (then dropped
    // when reopened), never two rows run together. A row the disk had no
    // room for is cut back off at once, so that no reader sees half of it.
    struct stat before;
    const bool  sized = ::fstat(fd_, &before) == 0;
    std::size_t done  = 0;
    while (done < line.size())
      {
        const ssize_t n = ::write(fd_, line.data() + done, line.size() - done);
        if (n < 0 && errno == EINTR)
          continue;
        if (n <= 0)
          {
            const int error = n < 0 ? errno : EIO;
            // If it cannot be cut back (a read-only disk), the Checkpoint
            // that reopens the file drops it.
            const bool left_cut = done > 0 && !(sized && ::ftruncate(fd_, before.st_size) == 0);
            throw std::runtime_error("cannot append to '" + path_.string() + "': " +
                                     (n < 0 ? std::strerror(error) : "nothing written") +
                                     (left_cut ? " (a row is left cut off there)" : "") +
                                     "; the rows before it are kept: run the same command again to go on");
          }
        done += static_cast<std::size_t>(n);
      }
  }
} // namespace rectify
