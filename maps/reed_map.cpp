#include "maps/reed_map.h"

#include <algorithm>
#include <cmath>

#include "common/case_file.h"
#include "common/io.h"
#include "maps/metadata.h"

namespace rectify::maps
{
  std::size_t ReedMap::index(const std::string &column, const std::string &where) const
  {
    const auto it = std::find(columns_.begin(), columns_.end(), column);
    if (it == columns_.end())
      throw InputError(where + ": the reed map '" + name_ + "' has no column '" + column + "'");
    return static_cast<std::size_t>(it - columns_.begin());
  }

  const std::vector<std::string> &ReedMap::columns()
  {
    static const std::vector<std::string> c{"thickness_m",           "stiffness_N_per_m",     "frequency_Hz",
                                            "modal_mass_kg",         "frequency_in_fluid_Hz", "modal_mass_in_fluid_kg",
                                            "effective_mass_eq321_kg", "frequency_eq321_Hz",
                                            "root_stress_per_opening_Pa_per_m",
                                            "root_stress_beam_per_opening_Pa_per_m",
                                            "root_stress_concentration",
                                            "second_mode_root_stress_per_opening_Pa_per_m",
                                            "n_dofs",                "wall_time_s"};
    return c;
  }

  ReedMap::ReedMap(std::vector<std::string> column_names, std::vector<std::vector<double>> rows, std::string name,
                   nlohmann::json metadata)
    : columns_(std::move(column_names))
    , rows_(std::move(rows))
    , name_(std::move(name))
    , metadata_(std::move(metadata))
  {
    const std::string where = "reed map '" + name_ + "'";
    if (columns_.size() < 2 || columns_[0] != "thickness_m" || columns_[1] != "stiffness_N_per_m")
      throw InputError(where + ": the first columns must be thickness_m and stiffness_N_per_m");
    if (rows_.empty())
      throw InputError(where + ": no rows");
    for (std::size_t r = 0; r < rows_.size(); ++r)
      {
        if (rows_[r].size() != columns_.size())
          throw InputError(where + " data row " + std::to_string(r + 1) + ": " + std::to_string(rows_[r].size()) +
                           " values, expected " + std::to_string(columns_.size()));
        for (std::size_t c = 0; c < rows_[r].size(); ++c)
          if (!std::isfinite(rows_[r][c]))
            throw InputError(where + " data row " + std::to_string(r + 1) + ": " + columns_[c] + " is not finite");
        if (r > 0 && !(rows_[r][0] > rows_[r - 1][0]))
          throw InputError(where + " data row " + std::to_string(r + 1) + ": thickness_m = " +
                           format_number(rows_[r][0]) + " does not increase");
      }
  }

  ReedMap ReedMap::read(const std::filesystem::path &path)
  {
    const CsvData  csv  = read_csv(path);
    nlohmann::json meta = read_metadata(csv, "reed map '" + path.string() + "'");
    // thickness and stiffness first, then every other column as it is
    std::vector<std::string> names{"thickness_m", "stiffness_N_per_m"};
    std::vector<std::size_t> index{csv.column_index("thickness_m", path.string()),
                                   csv.column_index("stiffness_N_per_m", path.string())};
    for (std::size_t c = 0; c < csv.columns.size(); ++c)
      if (c != index[0] && c != index[1])
        names.push_back(csv.columns[c]), index.push_back(c);
    std::vector<std::vector<double>> rows;
    for (const auto &row : csv.rows)
      {
        rows.emplace_back();
        for (auto i : index)
          rows.back().push_back(row[i]);
      }
    return ReedMap(std::move(names), std::move(rows), path.string(), std::move(meta));
  }

  void ReedMap::write(const std::filesystem::path &path) const
  {
    CsvTable table(columns_);
    for (const auto &r : rows_)
      table.add_row(r);
    write_file_atomic(path, "# rectify reed map: k_r, f1, masses and root stress vs reed thickness\n# meta: " + metadata_.dump() +
                              "\n" + table.to_string());
  }

  std::vector<double> ReedMap::column(const std::string &name) const
  {
    const auto          c = index(name, "reed map '" + name_ + "'");
    std::vector<double> v;
    for (const auto &r : rows_)
      v.push_back(r[c]);
    return v;
  }

  ReedMap::Properties ReedMap::at(double thickness, const std::string &mass_column, const std::string &where) const
  {
    const std::size_t cm = index(mass_column, where);
    const double      lo = rows_.front()[0], hi = rows_.back()[0];
    if (!(thickness >= lo && thickness <= hi))
      throw InputError(where + " = " + format_number(thickness) + ": outside the reed map '" + name_ + "' (" +
                       format_number(lo) + " .. " + format_number(hi) + " m)");
    std::size_t i = 0;
    while (i + 2 < rows_.size() && thickness > rows_[i + 1][0])
      ++i;
    const auto  &a = rows_[i];
    const auto  &b = rows_.size() > 1 ? rows_[i + 1] : rows_[i];
    const double s = b[0] > a[0] ? (thickness - a[0]) / (b[0] - a[0]) : 0.0;
    const auto   linear = [&](std::size_t c) { return a[c] + s * (b[c] - a[c]); };
    Properties   p{linear(1), linear(cm)};
    const auto   has    = [&](const char *c) { return std::find(columns_.begin(), columns_.end(), c) != columns_.end(); };
    if (has("root_stress_per_opening_Pa_per_m"))
      {
        p.root_stress_per_opening_Pa_per_m = linear(index("root_stress_per_opening_Pa_per_m", where));
        p.second_mode_root_stress_per_opening_Pa_per_m =
          has("second_mode_root_stress_per_opening_Pa_per_m")
            ? linear(index("second_mode_root_stress_per_opening_Pa_per_m", where))
            : 0.0;
        p.root_stress_concentration =
          has("root_stress_concentration") ? linear(index("root_stress_concentration", where)) : 1.0;
        if (!(p.root_stress_per_opening_Pa_per_m > 0))
          throw InputError("reed map '" + name_ + "': root_stress_per_opening_Pa_per_m = " +
                           format_number(p.root_stress_per_opening_Pa_per_m) + " at " + format_number(thickness) +
                           " m; it must be positive (the underside in tension while the reed opens)");
      }
    if (!(p.stiffness_N_per_m > 0) || !(p.mass_kg > 0))
      throw InputError("reed map '" + name_ + "': non-positive stiffness or mass at " + format_number(thickness) + " m");
    return p;
  }
} // namespace rectify::maps
