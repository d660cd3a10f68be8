#include "common/case_edit.h"

#include <regex>
#include <sstream>

namespace rectify
{
  namespace
  {
    std::string trim(const std::string &s)
    {
      const auto a = s.find_first_not_of(" \t\r");
      const auto b = s.find_last_not_of(" \t\r");
      return a == std::string::npos ? "" : s.substr(a, b - a + 1);
    }
  } // namespace

  std::string edit_case_text(const std::string &text, const std::filesystem::path &base_dir,
                             const std::vector<CaseEntry> &entries)
  {
    std::vector<std::string> lines;
    {
      std::istringstream in(text);
      for (std::string line; std::getline(in, line);)
        lines.push_back(line);
    }
    const std::regex table_re(R"(^\s*\[\s*([A-Za-z0-9_]+)\s*\]\s*(#.*)?$)");
    // An array of tables ([[port]]): its keys are no table's that an entry names.
    const std::regex array_table_re(R"(^\s*\[\[\s*([A-Za-z0-9_]+)\s*\]\]\s*(#.*)?$)");
    // a bare key, or a quoted one ([uncertain] "table.key" = [lo, hi])
    const std::regex key_re(R"re(^\s*"?([A-Za-z0-9_.]+)"?\s*=\s*(.*)$)re");
    const std::regex path_value_re(R"re(^"([^"]*)"(.*)$)re");
    std::string      table;
    std::vector<bool> done(entries.size(), false);
    std::vector<std::string> out;
    for (std::size_t e = 0; e < entries.size(); ++e) // one to comment out that the file lacks: nothing to do
      done[e] = entries[e].value.empty();
    const auto flush_table = [&](const std::string &t) {
      for (std::size_t e = 0; e < entries.size(); ++e)
        if (!done[e] && entries[e].table == t)
          {
            out.push_back(entries[e].key + " = " + entries[e].value + "  # " + entries[e].comment);
            done[e] = true;
          }
    };
    for (const auto &line : lines)
      {
        std::smatch m;
        if (std::regex_match(line, m, array_table_re))
          {
            flush_table(table);
            table = "[[" + m[1].str() + "]]";
            out.push_back(line);
            continue;
          }
        if (std::regex_match(line, m, table_re))
          {
            flush_table(table);
            table = m[1];
            out.push_back(line);
            continue;
          }
        if (std::regex_match(line, m, key_re))
          {
            const std::string key = m[1];
            bool              replaced = false;
            for (std::size_t e = 0; e < entries.size(); ++e)
              if (entries[e].table == table && entries[e].key == key)
                {
                  out.push_back(entries[e].value.empty() ? "# " + trim(line) + "  # " + entries[e].comment :
                                                           key + " = " + entries[e].value + "  # " +
                                                             entries[e].comment + " (was: " + trim(m[2]) + ")");
                  done[e]  = true;
                  replaced = true;
                }
            if (replaced)
              continue;
            const bool is_path =
              (table == "valves" &&
               (key == "resistance_map" || key == "map_set" || key == "outlet_map_set" || key == "inlet_map_set")) ||
              (table == "reed" && key == "properties_map") || (table == "drive" && key == "waveform") ||
              (table == "mesh" && key == "shape_table") || (table == "geometry" && key == "reed_outline_csv") ||
              (table == "[[port]]" && key == "outline_csv");
            std::smatch pv;
            const std::string value = m[2];
            if (is_path && std::regex_match(value, pv, path_value_re) && pv[1] != "sine" &&
                std::filesystem::path(pv[1].str()).is_relative())
              {
                out.push_back(key + " = \"" + std::filesystem::absolute(base_dir / pv[1].str()).lexically_normal().string() +
                              "\"" + pv[2].str());
                continue;
              }
          }
        out.push_back(line);
      }
    flush_table(table);
    std::string result;
    for (const auto &l : out)
      result += l + "\n";
    for (std::size_t e = 0; e < entries.size(); ++e)
      if (!done[e])
        {
          result += "\n[" + entries[e].table + "]\n";
          for (std::size_t f = e; f < entries.size(); ++f)
            if (!done[f] && entries[f].table == entries[e].table)
              {
                result += entries[f].key + " = " + entries[f].value + "  # " + entries[f].comment + "\n";
                done[f] = true;
              }
        }
    return result;
  }
} // namespace rectify
