#include "maps/area_map.h"

#include <cmath>
#include <sstream>

#include "common/case_file.h"
#include "common/io.h"
#include "maps/metadata.h"

namespace rectify::maps
{
  AreaMap::AreaMap(std::vector<double> openings_m, std::vector<double> areas_m2, std::string name,
                   nlohmann::json metadata)
    : opening_(std::move(openings_m))
    , area_(std::move(areas_m2))
    , name_(std::move(name))
    , metadata_(std::move(metadata))
  {
    const std::string where = "area map '" + name_ + "'";
    if (opening_.size() != area_.size())
      throw InputError(where + ": " + std::to_string(opening_.size()) + " openings but " +
                       std::to_string(area_.size()) + " areas");
    if (opening_.empty())
      throw InputError(where + ": has no nodes");
    for (std::size_t i = 0; i < opening_.size(); ++i)
      {
        const std::string row = where + " row " + std::to_string(i + 1);
        if (!std::isfinite(opening_[i]) || !std::isfinite(area_[i]))
          throw InputError(row + ": value is not finite");
        if (!(opening_[i] > 0))
          throw InputError(row + ": opening_m = " + format_number(opening_[i]) + " must be > 0");
        if (!(area_[i] > 0))
          throw InputError(row + ": A_eff_m2 = " + format_number(area_[i]) + " must be > 0");
        if (i > 0 && !(opening_[i] > opening_[i - 1]))
          throw InputError(row + ": opening_m = " + format_number(opening_[i]) +
                           " does not increase (previous " + format_number(opening_[i - 1]) + ")");
      }
    if (opening_.size() >= 2)
      {
        std::vector<double> log_x(opening_.size());
        for (std::size_t i = 0; i < opening_.size(); ++i)
          log_x[i] = std::log(opening_[i]);
        cubic_ = MonotoneCubic(log_x, area_);
      }
  }

  AreaMap AreaMap::constant(double area_m2, std::string name)
  {
    return AreaMap({1.0}, {area_m2}, std::move(name), {{"source", "constant"}});
  }

  AreaMap::Value AreaMap::evaluate(double x) const
  {
    if (opening_.size() < 2 || x <= opening_.front())
      return {area_.front(), 0.0};
    if (x >= opening_.back())
      return {area_.back(), 0.0};
    const auto v = cubic_.evaluate(std::log(x));
    return {v.value, v.derivative / x};
  }

  AreaMap AreaMap::read(const std::filesystem::path &path)
  {
    const CsvData  csv  = read_csv(path);
    nlohmann::json meta = read_metadata(csv, "area map '" + path.string() + "'");
    const std::size_t   cx = csv.column_index("opening_m", path.string());
    const std::size_t   ca = csv.column_index("A_eff_m2", path.string());
    std::vector<double> x, a;
    for (const auto &row : csv.rows)
      {
        x.push_back(row[cx]);
        a.push_back(row[ca]);
      }
    return AreaMap(std::move(x), std::move(a), path.string(), std::move(meta));
  }

  void AreaMap::write(const std::filesystem::path &path) const
  {
    std::ostringstream s;
    s << "# rectify area map: the reed's effective pressure area A_eff = F_z / dp [m^2] vs tip opening [m]\n"
      << "# meta: " << metadata_.dump() << "\n"
      << "opening_m,A_eff_m2\n";
    char buf[64];
    for (std::size_t i = 0; i < opening_.size(); ++i)
      {
        std::snprintf(buf, sizeof(buf), "%.17g,%.17g\n", opening_[i], area_[i]);
        s << buf;
      }
    write_file_atomic(path, s.str());
  }
} // namespace rectify::maps
