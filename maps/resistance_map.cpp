#include "maps/resistance_map.h"

#include <algorithm>
#include <cmath>
#include <sstream>

#include "common/case_file.h"
#include "common/io.h"
#include "maps/metadata.h"

namespace rectify::maps
{
  Interpolation parse_interpolation(const std::string &name)
  {
    if (name == "monotone-cubic")
      return Interpolation::monotone_cubic;
    if (name == "log-linear")
      return Interpolation::log_linear;
    if (name == "linear")
      return Interpolation::linear;
    if (name == "log-log")
      return Interpolation::log_log;
    throw InputError("unknown interpolation '" + name +
                     "' (monotone-cubic, log-linear, linear or log-log)");
  }

  std::string to_string(Interpolation interpolation)
  {
    switch (interpolation)
      {
        case Interpolation::monotone_cubic:
          return "monotone-cubic";
        case Interpolation::log_linear:
          return "log-linear";
        case Interpolation::linear:
          return "linear";
        case Interpolation::log_log:
          return "log-log";
      }
    return "?";
  }

  OutOfRange parse_out_of_range(const std::string &name)
  {
    if (name == "hold")
      return OutOfRange::hold;
    if (name == "error")
      return OutOfRange::error;
    throw InputError("unknown out-of-range policy '" + name + "' (hold or error)");
  }

  ResistanceMap::ResistanceMap(std::vector<double> openings_m, std::vector<double> resistances,
                               std::string name, nlohmann::json metadata,
                               Interpolation interpolation)
    : opening_(std::move(openings_m))
    , resistance_(std::move(resistances))
    , name_(std::move(name))
    , metadata_(std::move(metadata))
    , interpolation_(interpolation)
  {
    const std::string where = "resistance map '" + name_ + "'";
    if (opening_.size() != resistance_.size())
      throw InputError(where + ": " + std::to_string(opening_.size()) + " openings but " +
                       std::to_string(resistance_.size()) + " resistances");
    if (opening_.size() < 2)
      throw InputError(where + ": needs at least two nodes, has " +
                       std::to_string(opening_.size()));
    for (std::size_t i = 0; i < opening_.size(); ++i)
      {
        const std::string row = where + " row " + std::to_string(i + 1);
        if (!std::isfinite(opening_[i]) || !std::isfinite(resistance_[i]))
          throw InputError(row + ": value is not finite");
        if (resistance_[i] <= 0)
          throw InputError(row + ": R_Pa_s_per_m3 = " + format_number(resistance_[i]) +
                           " must be > 0");
        if (i == 0 && opening_[0] != 0.0)
          throw InputError(row + ": the first opening_m must be 0 (the closed valve), got " +
                           format_number(opening_[0]));
        if (i > 0 && !(opening_[i] > opening_[i - 1]))
          throw InputError(row + ": opening_m = " + format_number(opening_[i]) +
                           " does not increase (previous " + format_number(opening_[i - 1]) +
                           "): the map must be monotone");
        if (i > 0 && resistance_[i] > resistance_[i - 1])
          throw InputError(row + ": R_Pa_s_per_m3 = " + format_number(resistance_[i]) +
                           " rises above the previous " + format_number(resistance_[i - 1]) +
                           ": R must not increase with opening");
      }
    log_resistance_.resize(resistance_.size());
    std::transform(resistance_.begin(), resistance_.end(), log_resistance_.begin(),
                   [](double r) { return std::log(r); });

    // Fritsch-Carlson node slopes of log R (maps/monotone_cubic.h): monotone
    // data give a monotone interpolant.
    const std::size_t n = opening_.size();
    log_cubic_          = MonotoneCubic(opening_, log_resistance_);
    if (interpolation_ == Interpolation::log_log)
      {
        if (n < 3)
          throw InputError(where + ": log-log interpolation needs at least two open nodes (x > 0)");
        std::vector<double> log_x(n - 1), log_r(n - 1);
        for (std::size_t i = 1; i < n; ++i)
          log_x[i - 1] = std::log(opening_[i]), log_r[i - 1] = log_resistance_[i];
        log_log_        = MonotoneCubic(log_x, log_r);
        first_exponent_ = (log_r[1] - log_r[0]) / (log_x[1] - log_x[0]);
      }
  }

  ResistanceMap::Value ResistanceMap::evaluate(double x) const
  {
    if (x <= 0.0)
      return {resistance_.front(), 0.0, false};
    if (x >= opening_.back()) // held beyond the table: dR/dx may jump here
      return {resistance_.back(), 0.0, x > opening_.back()};
    if (interpolation_ == Interpolation::log_log)
      {
        if (x < opening_[1]) // the first interval's power law, up to the closed value
          {
            const double r = resistance_[1] * std::pow(x / opening_[1], first_exponent_);
            if (r >= resistance_.front())
              return {resistance_.front(), 0.0, false};
            return {r, r * first_exponent_ / x, false};
          }
        const auto   v = log_log_.evaluate(std::log(x));
        const double r = std::exp(v.value);
        return {r, r * v.derivative / x, false};
      }
    const auto   it = std::upper_bound(opening_.begin(), opening_.end(), x);
    const auto   i  = static_cast<std::size_t>(it - opening_.begin()) - 1;
    const double dx = opening_[i + 1] - opening_[i];
    const double s  = (x - opening_[i]) / dx;
    if (interpolation_ == Interpolation::linear)
      {
        const double slope = (resistance_[i + 1] - resistance_[i]) / dx;
        return {resistance_[i] + s * (resistance_[i + 1] - resistance_[i]), slope, false};
      }
    if (interpolation_ == Interpolation::log_linear)
      {
        const double dlog = log_resistance_[i + 1] - log_resistance_[i];
        const double r    = std::exp(log_resistance_[i] + s * dlog);
        return {r, r * dlog / dx, false};
      }
    // Cubic Hermite on log R.
    const auto   v = log_cubic_.evaluate(x);
    const double r = std::exp(v.value);
    return {r, r * v.derivative, false};
  }

  ResistanceMap ResistanceMap::read(const std::filesystem::path &path,
                                    Interpolation               interpolation)
  {
    const CsvData  csv = read_csv(path);
    nlohmann::json meta = read_metadata(csv, "resistance map '" + path.string() + "'");
    const std::size_t cx = csv.column_index("opening_m", path.string());
    const std::size_t cr = csv.column_index("R_Pa_s_per_m3", path.string());
    std::vector<double> x, r;
    for (const auto &row : csv.rows)
      {
        x.push_back(row[cx]);
        r.push_back(row[cr]);
      }
    return ResistanceMap(std::move(x), std::move(r), path.string(), std::move(meta),
                         interpolation);
  }

  void ResistanceMap::write(const std::filesystem::path &path) const
  {
    std::ostringstream s;
    s << "# rectify resistance map: valve flow resistance R [Pa s/m^3] vs tip opening [m]\n"
      << "# meta: " << metadata_.dump() << "\n"
      << "opening_m,R_Pa_s_per_m3\n";
    char buf[64];
    for (std::size_t i = 0; i < opening_.size(); ++i)
      {
        std::snprintf(buf, sizeof(buf), "%.17g,%.17g\n", opening_[i], resistance_[i]);
        s << buf;
      }
    write_file_atomic(path, s.str());
  }

  ResistanceMap thesis_resistance_map(std::size_t n_samples)
  {
    constexpr double r0 = 2.34e11, decay_per_um = 0.025;
    constexpr double r_closed = 1e17, r_floor = 4.5e8, x_floor = 5e-3;
    constexpr double x_first = 2e-6, x_last = 1210e-6;
    std::vector<double> x{0.0}, r{r_closed};
    for (std::size_t i = 0; i < n_samples; ++i)
      {
        const double s  = static_cast<double>(i) / static_cast<double>(n_samples - 1);
        const double xi = x_first * std::pow(x_last / x_first, s);
        x.push_back(xi);
        r.push_back(std::max(r0 * std::exp(-decay_per_um * xi * 1e6), r_floor));
      }
    x.push_back(x_floor);
    r.push_back(r_floor);
    nlohmann::json meta = {
      {"source", "thesis sec. 3.2.4, eq. 3.40: R = 2.34e11 exp(-0.025 x[um]), Fig. 3.7"},
      {"closed_R_Pa_s_per_m3", r_closed},
      {"floor_R_Pa_s_per_m3", r_floor},
      {"floor_opening_m", x_floor},
      {"samples", "log-spaced 2..1210 um, R = max(fit, floor)"},
      {"written_by", std::string("rectify ") + RECTIFY_VERSION}};
    return ResistanceMap(std::move(x), std::move(r), "thesis-fit", std::move(meta));
  }
} // namespace rectify::maps
