/* An LD_PRELOAD library that makes a folder's disk fail part-way through a
 * run, for the fault tests (tests/test_faults.cpp). Environment:
 *   RECTIFY_FAULT_DIR     the folder (absolute); files elsewhere are untouched
 *   RECTIFY_FAULT_AFTER   how many write() calls into it succeed
 *   RECTIFY_FAULT_ERRNO   "ENOSPC" (disk full: the failing call writes half
 *                         its bytes, as a full disk can, and every later
 *                         write fails) or "EROFS" (the folder turns
 *                         read-only: writes, opens for writing, renames,
 *                         removals and new folders fail)
 * Root ignores permission bits, so chmod cannot make a read-only folder for
 * a test run as root (CI); this can. It intercepts the C library calls that
 * rectify and libstdc++ make through the dynamic linker (open, fopen, write,
 * rename, unlink, mkdir); glibc's internal calls (fwrite's) it cannot see,
 * which is why rectify writes its files with open/write. */
#define _GNU_SOURCE
#include <dlfcn.h>
#include <errno.h>
#include <fcntl.h>
#include <limits.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/types.h>
#include <unistd.h>

static long n_writes = 0;

static const char *fault_dir(void) { return getenv("RECTIFY_FAULT_DIR"); }

static int fault_errno(void)
{
  const char *e = getenv("RECTIFY_FAULT_ERRNO");
  return e && strcmp(e, "EROFS") == 0 ? EROFS : ENOSPC;
}

static int under_dir(const char *path)
{
  const char *dir = fault_dir();
  if (!dir || !path)
    return 0;
  char full[PATH_MAX];
  if (path[0] != '/')
    {
      if (!getcwd(full, sizeof full))
        return 0;
      strncat(full, "/", sizeof full - strlen(full) - 1);
      strncat(full, path, sizeof full - strlen(full) - 1);
      path = full;
    }
  return strncmp(path, dir, strlen(dir)) == 0;
}

static int fd_under_dir(int fd)
{
  char link[64], target[PATH_MAX];
  snprintf(link, sizeof link, "/proc/self/fd/%d", fd);
  const ssize_t n = readlink(link, target, sizeof target - 1);
  if (n <= 0)
    return 0;
  target[n] = '\0';
  return under_dir(target);
}

static int failing(void)
{
  const char *after = getenv("RECTIFY_FAULT_AFTER");
  return after && n_writes >= atol(after);
}

/* Read-only: every change to the folder fails once the budget is spent. */
static int read_only_now(const char *path) { return fault_errno() == EROFS && failing() && under_dir(path); }

ssize_t write(int fd, const void *buf, size_t count)
{
  static ssize_t (*real)(int, const void *, size_t);
  if (!real)
    *(void **)&real = dlsym(RTLD_NEXT, "write"); /* POSIX: no cast to a function pointer */
  if (fd > 2 && fd_under_dir(fd))
    {
      if (failing())
        {
          errno = fault_errno();
          return -1;
        }
      if (++n_writes == atol(getenv("RECTIFY_FAULT_AFTER") ? getenv("RECTIFY_FAULT_AFTER") : "-1") &&
          fault_errno() == ENOSPC && count > 1)
        return real(fd, buf, count / 2); /* the disk fills during this write */
    }
  return real(fd, buf, count);
}

static int wants_write(int flags) { return (flags & (O_WRONLY | O_RDWR | O_CREAT | O_TRUNC | O_APPEND)) != 0; }

#define OPEN_LIKE(name)                                                                            \
  int name(const char *path, int flags, ...)                                                       \
  {                                                                                                \
    static int (*real)(const char *, int, ...);                                                    \
    if (!real)                                                                                     \
      *(void **)&real = dlsym(RTLD_NEXT, #name);                            \
    mode_t mode = 0;                                                                               \
    if (flags & O_CREAT)                                                                           \
      {                                                                                            \
        va_list ap;                                                                                \
        va_start(ap, flags);                                                                       \
        mode = va_arg(ap, mode_t);                                                                 \
        va_end(ap);                                                                                \
      }                                                                                            \
    if (wants_write(flags) && read_only_now(path))                                                 \
      {                                                                                            \
        errno = EROFS;                                                                             \
        return -1;                                                                                 \
      }                                                                                            \
    return real(path, flags, mode);                                                                \
  }
OPEN_LIKE(open)
OPEN_LIKE(open64)

#define FOPEN_LIKE(name)                                                                           \
  FILE *name(const char *path, const char *mode)                                                   \
  {                                                                                                \
    static FILE *(*real)(const char *, const char *);                                              \
    if (!real)                                                                                     \
      *(void **)&real = dlsym(RTLD_NEXT, #name);                     \
    if (strpbrk(mode, "wa+") && read_only_now(path))                                               \
      {                                                                                            \
        errno = EROFS;                                                                             \
        return NULL;                                                                               \
      }                                                                                            \
    return real(path, mode);                                                                       \
  }
FOPEN_LIKE(fopen)
FOPEN_LIKE(fopen64)

int rename(const char *from, const char *to)
{
  static int (*real)(const char *, const char *);
  if (!real)
    *(void **)&real = dlsym(RTLD_NEXT, "rename");
  if (read_only_now(from) || read_only_now(to))
    {
      errno = EROFS;
      return -1;
    }
  return real(from, to);
}

/* Calls that change the folder through one path: refused once read-only. */
#define ONE_PATH(name)                                                                             \
  int name(const char *path)                                                                       \
  {                                                                                                \
    static int (*real)(const char *);                                                              \
    if (!real)                                                                                     \
      *(void **)&real = dlsym(RTLD_NEXT, #name);                                                   \
    if (read_only_now(path))                                                                       \
      {                                                                                            \
        errno = EROFS;                                                                             \
        return -1;                                                                                 \
      }                                                                                            \
    return real(path);                                                                             \
  }
ONE_PATH(unlink)
ONE_PATH(remove)
ONE_PATH(rmdir)

int mkdir(const char *path, mode_t mode)
{
  static int (*real)(const char *, mode_t);
  if (!real)
    *(void **)&real = dlsym(RTLD_NEXT, "mkdir");
  if (read_only_now(path))
    {
      errno = EROFS;
      return -1;
    }
  return real(path, mode);
}
