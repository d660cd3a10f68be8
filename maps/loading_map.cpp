#include "maps/loading_map.h"

#include <cmath>
#include <cstdio>
#include <sstream>

#include "common/case_file.h"
#include "common/io.h"
#include "maps/metadata.h"

namespace rectify::maps
{
  namespace
  {
    const std::vector<std::string> columns{"opening_m",     "damping_fixed_dp_N_s_per_m", "A_modal_m2",
                                           "added_mass_kg", "damping_N_s_per_m",          "asymmetry"};
  }

  LoadingMap::LoadingMap(std::vector<Row> rows, std::string name, nlohmann::json metadata)
    : rows_(std::move(rows))
    , name_(std::move(name))
    , metadata_(std::move(metadata))
  {
    const std::string where = "loading map '" + name_ + "'";
    if (rows_.size() < 2)
      throw InputError(where + ": needs at least two openings, has " + std::to_string(rows_.size()));
    std::vector<double> lx, lc, a, lm;
    for (std::size_t i = 0; i < rows_.size(); ++i)
      {
        const Row        &r   = rows_[i];
        const std::string row = where + " row " + std::to_string(i + 1);
        const double      v[] = {r.opening_m, r.damping_fixed_dp_N_s_per_m, r.A_modal_m2, r.added_mass_kg,
                                 r.damping_N_s_per_m, r.asymmetry};
        for (std::size_t k = 0; k < columns.size(); ++k)
          if (!std::isfinite(v[k]))
            throw InputError(row + ": " + columns[k] + " = " + format_number(v[k]) + " is not finite");
        for (std::size_t k = 0; k < 5; ++k)
          if (!(v[k] > 0))
            throw InputError(row + ": " + columns[k] + " = " + format_number(v[k]) + " must be > 0");
        if (i > 0 && !(r.opening_m > rows_[i - 1].opening_m))
          throw InputError(row + ": opening_m = " + format_number(r.opening_m) + " does not increase (previous " +
                           format_number(rows_[i - 1].opening_m) + ")");
        lx.push_back(std::log(r.opening_m));
        lc.push_back(std::log(r.damping_fixed_dp_N_s_per_m));
        a.push_back(r.A_modal_m2);
        lm.push_back(std::log(r.added_mass_kg));
      }
    if (metadata_.is_object() && metadata_.contains("film_modal_area_m2"))
      {
        const auto &a = metadata_.at("film_modal_area_m2");
        if (!a.is_number() || !(a.get<double>() > 0) || !std::isfinite(a.get<double>()))
          throw InputError(where + ": meta film_modal_area_m2 = " + a.dump() + " must be a positive number");
        film_area_ = a.get<double>();
      }
    log_c_ = MonotoneCubic(lx, lc);
    a_     = MonotoneCubic(lx, a);
    log_m_ = MonotoneCubic(lx, lm);
  }

  LoadingMap::Value LoadingMap::evaluate(double x) const
  {
    const double x0 = rows_.front().opening_m;
    if (!(x > x0))
      { // f(x) = f0 (2 x0^2 / (x^2 + x0^2))^q: the first node's power law
        // (slope n = -q at x0, so value and slope are continuous there)
        // rounded off below x0, smooth, f(0) = 2^q f0
        const double s2 = x0 * x0, r = (x0 * x0 + s2) / (x * x + s2);
        // the cubics' slopes at the first node, from inside (they hold beyond it)
        const double t0 = std::log(x0) + 1e-9 * (std::log(rows_[1].opening_m) - std::log(x0));
        const auto   c0 = log_c_.evaluate(t0), m0 = log_m_.evaluate(t0);
        const double qc = -c0.derivative * (x0 * x0 + s2) / (2 * x0 * x0);
        const double qm = -m0.derivative * (x0 * x0 + s2) / (2 * x0 * x0);
        const double added = std::exp(m0.value) * std::pow(r, qm);
        return {std::exp(c0.value) * std::pow(r, qc), rows_.front().A_modal_m2, added,
                -2 * qm * added * x / (x * x + s2)};
      }
    if (x >= rows_.back().opening_m)
      return {rows_.back().damping_fixed_dp_N_s_per_m, rows_.back().A_modal_m2, rows_.back().added_mass_kg, 0.0};
    const double t = std::log(x);
    const auto   m = log_m_.evaluate(t);
    const double added = std::exp(m.value);
    return {std::exp(log_c_.evaluate(t).value), a_.evaluate(t).value, added, added * m.derivative / x};
  }

  LoadingMap LoadingMap::read(const std::filesystem::path &path)
  {
    const CsvData  csv  = read_csv(path);
    nlohmann::json meta = read_metadata(csv, "loading map '" + path.string() + "'");
    std::vector<std::size_t> index;
    for (const auto &c : columns)
      index.push_back(csv.column_index(c, path.string()));
    std::vector<Row> rows;
    for (const auto &r : csv.rows)
      rows.push_back({r[index[0]], r[index[1]], r[index[2]], r[index[3]], r[index[4]], r[index[5]]});
    return LoadingMap(std::move(rows), path.string(), std::move(meta));
  }

  void LoadingMap::write(const std::filesystem::path &path) const
  {
    std::ostringstream s;
    s << "# rectify loading map: the reed's fluid loading vs tip opening [m], referred to the tip "
         "(docs/fluid-loading.md)\n"
      << "# meta: " << metadata_.dump() << "\n";
    for (std::size_t k = 0; k < columns.size(); ++k)
      s << (k ? "," : "") << columns[k];
    s << "\n";
    char buf[256];
    for (const auto &r : rows_)
      {
        std::snprintf(buf, sizeof(buf), "%.17g,%.17g,%.17g,%.17g,%.17g,%.17g\n", r.opening_m,
                      r.damping_fixed_dp_N_s_per_m, r.A_modal_m2, r.added_mass_kg, r.damping_N_s_per_m, r.asymmetry);
        s << buf;
      }
    write_file_atomic(path, s.str());
  }
} // namespace rectify::maps
