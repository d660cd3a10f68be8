// Plots through gnuplot: a script beside each figure (so a user can restyle
// it), rendered to PNG and SVG. Missing gnuplot is a notice, not an error: the
// CSV data are the result, the figure is a view of them.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

namespace rectify
{
  struct PlotSeries
  {
    std::filesystem::path data_file; ///< CSV with a header row
    std::string           x_column;
    std::string           y_column;
    std::string           title;
    std::string           style   = "lines"; ///< gnuplot style: "lines", "linespoints", "points"
    double                x_scale = 1.0;     ///< plotted x = column * x_scale
    double                y_scale = 1.0;
    std::size_t           stride  = 1; ///< plot every stride-th row (long time series)
  };

  struct PlotPanel
  {
    std::string             title;
    std::string             x_label;
    std::string             y_label;
    bool                    log_x = false;
    bool                    log_y = false;
    std::vector<PlotSeries> series;
    bool                    equal_axes = false; ///< one unit as long on both axes (drawings)
    /// Horizontal dashed lines across the panel (a limit: the reed's stop,
    /// the map's end), in plotted units, each named in the key.
    struct Level
    {
      double      y;
      std::string title;
    };
    std::vector<Level> levels = {};
  };

  /// Writes `<base>.gp` and renders `<base>.png` and `<base>.svg` (panels
  /// stacked vertically; each rendered under a temporary name and renamed).
  /// Returns false if gnuplot is not available or failed; the script, which a
  /// user can edit and run again (`gnuplot <base>.gp`), is written either way.
  bool render_plot(const std::filesystem::path &base, const std::vector<PlotPanel> &panels);
} // namespace rectify
