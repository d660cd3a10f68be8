#include "whatif/designs.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <map>
#include <regex>
#include <set>
#include <sstream>

#include "common/case_file.h"

namespace rectify::whatif
{
  namespace
  {
    const std::regex key_re(R"(^([A-Za-z][A-Za-z0-9_]*)\.([A-Za-z][A-Za-z0-9_]*)$)");

    std::string trim(const std::string &s)
    {
      const auto a = s.find_first_not_of(" \t\r");
      const auto b = s.find_last_not_of(" \t\r");
      return a == std::string::npos ? "" : s.substr(a, b - a + 1);
    }

    /// A finite number filling all of `text`, or nothing.
    bool parse_number(const std::string &text, double &value)
    {
      if (text.empty())
        return false;
      std::size_t used = 0;
      try
        {
          value = std::stod(text, &used);
        }
      catch (const std::exception &)
        {
          return false;
        }
      return used == text.size() && std::isfinite(value);
    }

    /// A cell as TOML: numbers as they are, true/false, the rest as a quoted string.
    std::string toml_value(const std::string &cell)
    {
      double v = 0;
      if (parse_number(cell, v) || cell == "true" || cell == "false")
        return cell;
      std::string t = cell;
      if (t.size() >= 2 && t.front() == '"' && t.back() == '"')
        t = t.substr(1, t.size() - 2);
      std::string quoted = "\"";
      for (char c : t)
        {
          if (c == '"' || c == '\\')
            quoted += '\\';
          quoted += c;
        }
      return quoted + "\"";
    }

    std::string design_name(std::size_t i, std::size_t n)
    {
      const int width = n < 100 ? 2 : n < 1000 ? 3 : static_cast<int>(std::to_string(n).size());
      char      buf[32];
      std::snprintf(buf, sizeof(buf), "d%0*zu", width, i + 1);
      return buf;
    }

    /// Splits one CSV line (no quoted commas: case values need none).
    std::vector<std::string> split(const std::string &line)
    {
      std::vector<std::string> cells;
      std::stringstream        in(line);
      for (std::string cell; std::getline(in, cell, ',');)
        cells.push_back(trim(cell));
      if (!line.empty() && line.back() == ',')
        cells.push_back("");
      return cells;
    }
  } // namespace

  Variation parse_variation(const std::string &spec)
  {
    const auto fail = [&](const std::string &why) -> Variation {
      throw InputError("--vary '" + spec + "': " + why +
                       " (expected table.key=FROM:TO:N, e.g. geometry.reed_thickness_m=0.08e-3:0.25e-3:10)");
    };
    const auto eq = spec.find('=');
    if (eq == std::string::npos)
      return fail("no '='");
    Variation   v;
    std::smatch m;
    const std::string key = trim(spec.substr(0, eq));
    if (!std::regex_match(key, m, key_re))
      return fail("'" + key + "' is not a case key of the form table.key");
    v.table = m[1];
    v.key   = m[2];
    v.spec  = spec;
    std::vector<std::string> parts;
    {
      std::stringstream in(spec.substr(eq + 1));
      for (std::string part; std::getline(in, part, ':');)
        parts.push_back(trim(part));
    }
    bool log_spacing = false;
    if (parts.size() == 4 && parts[3] == "log")
      {
        log_spacing = true;
        parts.pop_back();
      }
    if (parts.size() != 3)
      return fail("the range needs FROM:TO:N");
    double from = 0, to = 0, n_real = 0;
    if (!parse_number(parts[0], from))
      return fail("FROM '" + parts[0] + "' is not a finite number");
    if (!parse_number(parts[1], to))
      return fail("TO '" + parts[1] + "' is not a finite number");
    if (!parse_number(parts[2], n_real) || n_real != std::floor(n_real))
      return fail("N '" + parts[2] + "' is not a whole number");
    if (n_real < 1)
      return fail("N = " + parts[2] + ": must be at least 1");
    if (n_real > 100000)
      return fail("N = " + parts[2] + ": more than 100000 designs in one range");
    if (from > to)
      return fail("FROM " + parts[0] + " is above TO " + parts[1]);
    const auto n = static_cast<std::size_t>(n_real);
    if (n == 1 && from != to)
      return fail("N = 1 needs FROM = TO");
    if (log_spacing && !(from > 0))
      return fail("log spacing needs FROM > 0");
    for (std::size_t i = 0; i < n; ++i)
      {
        const double t = n == 1 ? 0.0 : static_cast<double>(i) / static_cast<double>(n - 1);
        double       x = log_spacing ? from * std::pow(to / from, t) : from + (to - from) * t;
        // 12 significant digits: 1.5e-4, not 1.4999999999999999e-4 (a design's
        // name for its value); the ends exactly as given.
        char buf[32];
        std::snprintf(buf, sizeof(buf), "%.12g", x);
        x = i == 0 ? from : i + 1 == n ? to : std::stod(buf);
        v.values.push_back(x);
      }
    return v;
  }

  nlohmann::json Design::values() const
  {
    nlohmann::json j = nlohmann::json::object();
    for (std::size_t i = 0; i < entries.size(); ++i)
      {
        double v = 0;
        if (parse_number(text_values[i], v))
          j[entries[i].table + "." + entries[i].key] = v;
        else
          j[entries[i].table + "." + entries[i].key] = text_values[i];
      }
    return j;
  }

  std::vector<Design> grid_designs(const std::vector<Variation> &variations)
  {
    std::set<std::string> seen;
    std::size_t           n = 1;
    for (const auto &v : variations)
      {
        if (!seen.insert(v.name()).second)
          throw InputError("--vary " + v.name() + " is given twice");
        n *= v.values.size();
        if (n > 100000)
          throw InputError("--vary: the grid has more than 100000 designs");
      }
    std::vector<Design> designs;
    if (variations.empty())
      return designs;
    for (std::size_t i = 0; i < n; ++i)
      {
        Design      d;
        std::size_t rest = i;
        d.entries.resize(variations.size());
        d.text_values.resize(variations.size());
        for (std::size_t k = variations.size(); k-- > 0;)
          {
            const auto &v     = variations[k];
            const double x    = v.values[rest % v.values.size()];
            rest /= v.values.size();
            d.entries[k]      = {v.table, v.key, format_number(x), "what-if"};
            d.text_values[k]  = format_number(x);
          }
        d.name = design_name(i, n);
        designs.push_back(std::move(d));
      }
    return designs;
  }

  std::vector<Design> read_designs_table(const std::filesystem::path &path)
  {
    std::ifstream in(path);
    if (!in)
      throw InputError("designs table '" + path.string() + "': cannot be read");
    std::vector<std::vector<std::string>> rows;
    std::vector<std::size_t>              line_numbers;
    std::size_t                           line_number = 0;
    for (std::string line; std::getline(in, line);)
      {
        ++line_number;
        line = trim(line);
        if (line.empty() || line[0] == '#')
          continue;
        rows.push_back(split(line));
        line_numbers.push_back(line_number);
      }
    const std::string where = "designs table '" + path.string() + "'";
    if (rows.empty())
      throw InputError(where + ": empty (expected a header row of case keys, table.key, and a row per design)");
    const auto &header = rows[0];
    long        name_column = -1;
    std::vector<std::pair<std::string, std::string>> keys(header.size());
    std::set<std::string>                            seen;
    for (std::size_t c = 0; c < header.size(); ++c)
      {
        if (header[c] == "name")
          {
            if (name_column >= 0)
              throw InputError(where + ": two 'name' columns");
            name_column = static_cast<long>(c);
            continue;
          }
        std::smatch m;
        if (!std::regex_match(header[c], m, key_re))
          throw InputError(where + ", column " + std::to_string(c + 1) + ": '" + header[c] +
                           "' is not a case key of the form table.key (or 'name')");
        if (!seen.insert(header[c]).second)
          throw InputError(where + ": column '" + header[c] + "' is given twice");
        keys[c] = {m[1], m[2]};
      }
    if (seen.empty())
      throw InputError(where + ": no case key column (table.key)");
    if (rows.size() == 1)
      throw InputError(where + ": no design rows under the header");
    std::vector<Design>   designs;
    std::set<std::string> names;
    const std::regex      name_re(R"(^[A-Za-z0-9][A-Za-z0-9_.+-]*$)");
    for (std::size_t r = 1; r < rows.size(); ++r)
      {
        const std::string at = where + ", line " + std::to_string(line_numbers[r]);
        if (rows[r].size() != header.size())
          throw InputError(at + ": " + std::to_string(rows[r].size()) + " cells, the header has " +
                           std::to_string(header.size()));
        Design d;
        d.name = name_column >= 0 ? rows[r][static_cast<std::size_t>(name_column)] : design_name(r - 1, rows.size() - 1);
        if (!std::regex_match(d.name, name_re))
          throw InputError(at + ": design name '" + d.name + "' (letters, digits, _ . + - only)");
        if (!names.insert(d.name).second)
          throw InputError(at + ": design name '" + d.name + "' is given twice");
        for (std::size_t c = 0; c < header.size(); ++c)
          {
            if (static_cast<long>(c) == name_column)
              continue;
            if (rows[r][c].empty())
              throw InputError(at + ", column '" + header[c] + "': empty");
            d.entries.push_back({keys[c].first, keys[c].second, toml_value(rows[r][c]), "what-if"});
            d.text_values.push_back(rows[r][c]);
          }
        designs.push_back(std::move(d));
      }
    return designs;
  }

  std::vector<std::string> design_keys(const std::vector<Design> &designs)
  {
    std::vector<std::string> keys;
    for (const auto &d : designs)
      for (const auto &e : d.entries)
        if (std::find(keys.begin(), keys.end(), e.table + "." + e.key) == keys.end())
          keys.push_back(e.table + "." + e.key);
    return keys;
  }

  std::string design_case_text(const std::string &base_text, const std::filesystem::path &base_dir,
                               const Design &design)
  {
    auto entries = design.entries;
    for (auto &e : entries)
      e.comment = "what-if design " + design.name;
    return edit_case_text(base_text, base_dir, entries);
  }
} // namespace rectify::whatif
