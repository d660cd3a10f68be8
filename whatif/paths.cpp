#include "whatif/paths.h"

#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <fstream>
#include <sstream>
#include <system_error>

#include "common/io.h"

namespace rectify::whatif
{
  namespace fs = std::filesystem;

  std::string exact(double x)
  {
    char buf[40];
    std::snprintf(buf, sizeof(buf), "%.17g", x);
    return buf;
  }

  std::string read_text(const fs::path &path)
  {
    std::ifstream in(path);
    if (!in)
      throw InputError("'" + path.string() + "' cannot be read");
    std::ostringstream s;
    s << in.rdbuf();
    return s.str();
  }

  nlohmann::json read_json_file(const fs::path &path)
  {
    try
      {
        return nlohmann::json::parse(read_text(path));
      }
    catch (const nlohmann::json::exception &e)
      {
        throw InputError("'" + path.string() + "': malformed JSON (" + e.what() + ")");
      }
  }

  std::string openings_header()
  {
    std::string header;
    for (const auto &c : stokes::OpeningPoint::columns())
      header += (header.empty() ? "" : ",") + c;
    return header;
  }

  stokes::OpeningPoint read_opening(const fs::path &file)
  {
    const auto csv = read_csv(file);
    if (csv.columns != stokes::OpeningPoint::columns() || csv.rows.size() != 1)
      throw InputError("'" + file.string() + "': not one opening's record (columns " + openings_header() + ")");
    return stokes::OpeningPoint::from_row(csv.rows[0]);
  }

  std::map<double, stokes::OpeningPoint> read_openings(const fs::path &work)
  {
    std::map<double, stokes::OpeningPoint> points;
    const fs::path                         dir = work / "openings";
    if (!fs::exists(dir))
      return points;
    for (const auto &entry : fs::directory_iterator(dir))
      {
        const std::string name = entry.path().filename().string();
        if (name.rfind("x-", 0) != 0 || entry.path().extension() != ".csv")
          continue; // a temporary a kill left
        const auto p        = read_opening(entry.path());
        points[p.opening_m] = p;
      }
    return points;
  }

  std::vector<Failure> read_failures(const Paths &paths)
  {
    std::vector<fs::path> files;
    if (fs::exists(paths.failures()))
      for (const auto &e : fs::directory_iterator(paths.failures()))
        if (e.path().extension() == ".json")
          files.push_back(e.path());
    std::sort(files.begin(), files.end());
    std::vector<Failure> failures;
    for (const auto &f : files)
      try
        {
          const auto j = read_json_file(f);
          failures.push_back({j.at("job").get<std::string>(), j.at("reason").get<std::string>(),
                              j.at("designs").get<std::vector<std::string>>()});
        }
      catch (const nlohmann::json::exception &e)
        {
          throw InputError("'" + f.string() + "': not a failure record (" + e.what() + ")");
        }
    return failures;
  }

  void publish(const fs::path &from, const fs::path &to)
  {
    ensure_directory(to.parent_path());
    for (int attempt = 0; attempt < 2; ++attempt)
      {
        std::error_code ec;
        fs::rename(from, to, ec);
        if (!ec)
          return;
        if (fs::exists(to / "manifest.json"))
          {
            fs::remove_all(from); // another batch with this cache made it meanwhile
            return;
          }
        if (fs::exists(to))
          {
            fs::remove_all(to); // what a killed copy left
            continue;
          }
        if (ec == std::errc::cross_device_link)
          {
            const fs::path part = to.parent_path() / (to.filename().string() + ".part." + std::to_string(getpid()));
            fs::remove_all(part);
            fs::copy(from, part, fs::copy_options::recursive);
            fs::rename(part, to);
            fs::remove_all(from);
            return;
          }
        throw std::runtime_error("cannot move the map set '" + from.string() + "' into the cache '" + to.string() +
                                 "': " + ec.message());
      }
  }
} // namespace rectify::whatif
