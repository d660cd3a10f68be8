#include "common/output_lock.h"

#include <cerrno>
#include <cstring>
#include <fcntl.h>
#include <fstream>
#include <sstream>
#include <sys/file.h>
#include <sys/stat.h>
#include <sys/sysmacros.h>
#include <unistd.h>

#include "common/case_file.h"
#include "common/io.h"

namespace rectify
{
  namespace
  {
    bool all_digits(const std::string &s)
    {
      if (s.empty())
        return false;
      for (const char c : s)
        if (c < '0' || c > '9')
          return false;
      return true;
    }

    /// The pid holding a flock on `fd`'s file, from /proc/locks; 0 if unknown.
    long lock_holder(int fd)
    {
      struct stat st;
      if (::fstat(fd, &st) != 0)
        return 0;
      char id[64];
      std::snprintf(id, sizeof(id), "%02x:%02x:%lu", major(st.st_dev), minor(st.st_dev),
                    static_cast<unsigned long>(st.st_ino));
      std::ifstream in("/proc/locks");
      for (std::string line; std::getline(in, line);)
        {
          std::istringstream fields(line);
          std::string        number, kind, mode, access, pid, file;
          fields >> number >> kind;
          if (kind == "->") // a waiter: "N: -> FLOCK ..."
            continue;
          fields >> mode >> access >> pid >> file;
          if (kind == "FLOCK" && file == id && all_digits(pid))
            return std::stol(pid);
        }
      return 0;
    }

    /// "pid N: rectify sweep --out ..." for the message; "" if unknown.
    std::string describe_process(long pid)
    {
      if (pid <= 0)
        return "";
      std::ifstream in("/proc/" + std::to_string(pid) + "/cmdline", std::ios::binary);
      std::string   cmdline((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
      for (char &c : cmdline)
        if (c == '\0')
          c = ' ';
      while (!cmdline.empty() && cmdline.back() == ' ')
        cmdline.pop_back();
      if (cmdline.size() > 160)
        cmdline = cmdline.substr(0, 157) + "...";
      return "pid " + std::to_string(pid) + (cmdline.empty() ? "" : ": " + cmdline);
    }

    std::string in_use_message(const std::filesystem::path &dir, int fd)
    {
      const std::string holder = describe_process(lock_holder(fd));
      return "output folder '" + dir.string() + "' is in use by another process" +
             (holder.empty() ? "" : " (" + holder + ")") +
             "; wait for it to finish, or choose another --out";
    }

    int open_folder(const std::filesystem::path &dir)
    {
      return ::open(dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
    }

    std::size_t remove_leftovers(const std::filesystem::path &dir)
    {
      namespace fs = std::filesystem;
      std::size_t     n = 0;
      std::error_code ec;
      for (fs::recursive_directory_iterator it(dir, fs::directory_options::skip_permission_denied, ec), end;
           !ec && it != end; it.increment(ec))
        if (it->is_regular_file(ec) && is_leftover_temporary(it->path().filename().string()))
          {
            std::error_code rm;
            if (fs::remove(it->path(), rm))
              ++n;
          }
      return n;
    }
  } // namespace

  bool is_leftover_temporary(const std::string &name)
  {
    const auto tmp = name.rfind(".tmp.");
    if (tmp != std::string::npos && tmp > 0 && all_digits(name.substr(tmp + 5)))
      return true;
    if (name.size() > 5 && name.compare(name.size() - 5, 5, ".part") == 0)
      return true;
    const std::string probe = ".rectify-write-test-";
    return name.rfind(probe, 0) == 0 && all_digits(name.substr(probe.size()));
  }

  OutputLock::~OutputLock()
  {
    if (fd_ >= 0)
      ::close(fd_); // releases the lock
  }

  OutputLock::OutputLock(OutputLock &&other) noexcept
    : fd_(other.fd_)
    , dir_(std::move(other.dir_))
    , n_removed_(other.n_removed_)
  {
    other.fd_ = -1;
  }

  OutputLock &OutputLock::operator=(OutputLock &&other) noexcept
  {
    if (this != &other)
      {
        if (fd_ >= 0)
          ::close(fd_);
        fd_       = other.fd_;
        dir_      = std::move(other.dir_);
        n_removed_ = other.n_removed_;
        other.fd_ = -1;
      }
    return *this;
  }

  void OutputLock::acquire(const std::filesystem::path &dir)
  {
    if (fd_ >= 0)
      {
        if (dir != dir_)
          throw std::logic_error("OutputLock: holds '" + dir_.string() + "', asked for '" + dir.string() + "'");
        return;
      }
    ensure_directory(dir);
    const int fd = open_folder(dir);
    if (fd < 0)
      throw InputError("cannot open output folder '" + dir.string() + "': " + std::strerror(errno));
    if (::flock(fd, LOCK_EX | LOCK_NB) != 0)
      {
        const int         error   = errno;
        const std::string message = error == EWOULDBLOCK ?
                                      in_use_message(dir, fd) :
                                      "cannot lock output folder '" + dir.string() + "': " + std::strerror(error);
        ::close(fd);
        throw InputError(message);
      }
    fd_        = fd;
    dir_       = dir;
    n_removed_ = remove_leftovers(dir);
  }

  void OutputLock::acquire_if_exists(const std::filesystem::path &dir)
  {
    std::error_code ec;
    if (std::filesystem::is_directory(dir, ec))
      acquire(dir);
  }

} // namespace rectify
