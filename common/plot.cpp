#include "common/plot.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <sstream>

#include "common/io.h"

namespace rectify
{
  namespace
  {
    /// 1-based gnuplot column of `name` in the CSV header of `file`.
    int column_number(const std::filesystem::path &file, const std::string &name)
    {
      std::ifstream in(file);
      std::string   line;
      while (std::getline(in, line))
        if (!line.empty() && line[0] != '#')
          break;
      std::istringstream header(line);
      std::string        cell;
      for (int c = 1; std::getline(header, cell, ','); ++c)
        if (cell == name)
          return c;
      throw std::logic_error("plot: no column '" + name + "' in " + file.string());
    }

    /// Whether `file` has a row whose columns `cx` and `cy` (1-based) both
    /// hold finite numbers: gnuplot refuses a plot whose every series is
    /// empty (a what-if whose designs have no valid run leaves its answer
    /// columns blank).
    bool has_points(const std::filesystem::path &file, int cx, int cy)
    {
      std::ifstream in(file);
      std::string   line;
      bool          header = true;
      while (std::getline(in, line))
        {
          if (line.empty() || line[0] == '#')
            continue;
          if (header)
            {
              header = false;
              continue;
            }
          std::istringstream row(line);
          std::string        cell;
          bool               x_ok = false, y_ok = false;
          for (int c = 1; std::getline(row, cell, ','); ++c)
            if (c == cx || c == cy)
              {
                char        *end = nullptr;
                const double v   = std::strtod(cell.c_str(), &end);
                const bool   ok  = !cell.empty() && end != cell.c_str() && std::isfinite(v);
                (c == cx ? x_ok : y_ok) = ok;
                if (cx == cy)
                  x_ok = y_ok = ok;
              }
          if (x_ok && y_ok)
            return true;
        }
      return false;
    }

    std::string quote(const std::string &s)
    {
      std::string out = "\"";
      for (char c : s)
        out += (c == '"' ? std::string("\\\"") : std::string(1, c));
      return out + "\"";
    }

    std::string script_body(const std::vector<PlotPanel> &panels)
    {
      std::ostringstream s;
      s << "set datafile separator ','\nset grid\nset key outside right top\n";
      if (panels.size() > 1)
        s << "set multiplot layout " << panels.size() << ",1\n";
      for (const auto &p : panels)
        {
          s << "set title " << quote(p.title) << "\nset xlabel " << quote(p.x_label)
            << "\nset ylabel " << quote(p.y_label) << "\n"
            << (p.log_x ? "set logscale x\n" : "unset logscale x\n")
            << (p.log_y ? "set logscale y\n" : "unset logscale y\n")
            << (p.equal_axes ? "set size ratio -1\nset offsets graph 0.04, graph 0.04, graph 0.04, graph 0.04\n" : "");
          std::vector<std::string> drawn;
          for (const auto &r : p.series)
            {
              const int cx = column_number(r.data_file, r.x_column);
              const int cy = column_number(r.data_file, r.y_column);
              if (!has_points(r.data_file, cx, cy))
                continue;
              std::ostringstream one;
              one << quote(r.data_file.filename().string()) << " every " << std::max<std::size_t>(r.stride, 1)
                  << "::1 using ($" << cx << "*" << r.x_scale << "):($" << cy << "*" << r.y_scale << ") with "
                  << r.style << " title " << quote(r.title);
              drawn.push_back(one.str());
            }
          if (drawn.empty())
            {
              // An empty panel, said so: no series has a point to draw.
              s << "unset logscale\nset xrange [0:1]\nset yrange [0:1]\nset label 1 "
                << quote("no points to draw (every value blank or not a number)") << " at graph 0.5, 0.5 center\n"
                << "plot NaN notitle\nunset label 1\nset autoscale xy\n";
              continue;
            }
          for (std::size_t i = 0; i < drawn.size(); ++i)
            s << (i ? ", \\\n     " : "plot ") << drawn[i];
          for (const auto &level : p.levels)
            s << ", \\\n     " << level.y << " with lines dt 2 lw 1.5 title " << quote(level.title);
          s << "\n";
        }
      if (panels.size() > 1)
        s << "unset multiplot\n";
      return s.str();
    }
  } // namespace

  bool render_plot(const std::filesystem::path &base, const std::vector<PlotPanel> &panels)
  {
    const std::string body   = script_body(panels);
    const auto        dir    = base.parent_path().empty() ? std::filesystem::path(".")
                                                          : base.parent_path();
    const std::string stem   = base.filename().string();
    const int         height = 360 * static_cast<int>(panels.size()) + 60;
    std::ostringstream script;
    script << "# gnuplot script written by rectify; run from this folder: gnuplot " << stem
           << ".gp\n"
           << "if (!exists('png')) png = '" << stem << ".png'\n"
           << "if (!exists('svg')) svg = '" << stem << ".svg'\n"
           << "set terminal pngcairo size 1000," << height << " noenhanced\n"
           << "set output png\n"
           << body << "set terminal svg size 1000," << height << " noenhanced\n"
           << "set output svg\n"
           << body << "set output\n";
    write_file_atomic(dir / (stem + ".gp"), script.str());

    const std::string command = "cd '" + dir.string() + "' && gnuplot -e \"png='" + stem +
                                ".png.part'; svg='" + stem + ".svg.part'\" '" + stem + ".gp' > '" +
                                stem + ".gp.log' 2>&1";
    if (std::system("command -v gnuplot > /dev/null 2>&1") != 0)
      return false;
    const bool ok = std::system(command.c_str()) == 0;
    for (const char *ext : {".png", ".svg"})
      {
        const auto part = dir / (stem + ext + ".part");
        if (ok && std::filesystem::exists(part))
          std::filesystem::rename(part, dir / (stem + ext));
        else
          std::filesystem::remove(part);
      }
    if (ok)
      std::filesystem::remove(dir / (stem + ".gp.log"));
    return ok;
  }
} // namespace rectify
