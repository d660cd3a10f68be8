#include "diagnosis/measured_run.h"
#include "diagnosis/residuals.h"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <regex>
#include <sstream>

#include "common/case_file.h"
#include "common/io.h"
#include "diagnosis/fourier.h"
#include "diagnosis/golden_section.h"

namespace rectify::diagnosis
{
  namespace
  {
    /// Known quantities: the column name's stem and the one unit accepted.
    struct Quantity
    {
      const char *stem;
      const char *column;
    };
    constexpr Quantity known[] = {{"time", "time_s"},
                                  {"current", "current_A"},
                                  {"voltage", "voltage_V"},
                                  {"outlet_pressure", "outlet_pressure_Pa"},
                                  {"chamber_pressure", "chamber_pressure_Pa"},
                                  {"outlet_valve", "outlet_valve_m"},
                                  {"strain", "strain"},
                                  {"actuator_position", "actuator_position_m"},
                                  {"actuator_velocity", "actuator_velocity_m_per_s"}};
    constexpr std::size_t min_rows = 20;
  } // namespace

  const std::vector<double> &MeasuredRun::signal(const std::string &column) const
  {
    const auto it = signals.find(column);
    if (it == signals.end())
      throw InputError("'" + source + "': no column '" + column + "'");
    return it->second;
  }

  const std::string &MeasuredRun::drive_column() const
  {
    static const std::string current = "current_A", voltage = "voltage_V";
    return has(current) ? current : voltage;
  }

  double MeasuredRun::drive_frequency_Hz() const
  {
    const auto  &u  = signal(drive_column());
    const auto [lo, hi] = std::minmax_element(u.begin(), u.end());
    const double mid = 0.5 * (*lo + *hi), band = 0.1 * (*hi - *lo);
    // Upward crossings of mid + band after having been below mid - band.
    std::vector<double> ups;
    bool                below = false;
    for (std::size_t i = 1; i < u.size(); ++i)
      {
        below = below || u[i - 1] < mid - band;
        if (below && u[i - 1] < mid + band && u[i] >= mid + band)
          {
            const double w = (mid + band - u[i - 1]) / (u[i] - u[i - 1]);
            ups.push_back(time_s[i - 1] + w * (time_s[i] - time_s[i - 1]));
            below = false;
          }
      }
    if (!(*hi > *lo) || ups.size() < 2)
      throw InputError("'" + source + "': the drive (" + drive_column() +
                       ") shows fewer than two cycles: too short a record, or give the pumping frequency");
    const double coarse = static_cast<double>(ups.size() - 1) / (ups.back() - ups.front());
    // The crossings' times carry the noise over the drive's slope: at 1 %
    // noise the estimate is off by ~1e-4, which over 16 cycles shifts the
    // drive's phase by a hundredth of a radian (more than its noise). Refined
    // by least squares: the frequency whose Fourier series (mean and 5
    // harmonics) leaves the smallest residual, by golden section within
    // +-0.5 / (cycles recorded) of the crossings' estimate (inside the
    // residual's main lobe).
    const double duration = time_s.back() - time_s.front();
    const Eigen::Map<const Eigen::VectorXd> b(u.data(), static_cast<Eigen::Index>(u.size()));
    const auto misfit = [&](double f) {
      const Eigen::MatrixXd A = fourier_basis(time_s, f, 5);
      const Eigen::VectorXd c = (A.transpose() * A).ldlt().solve(A.transpose() * b);
      return (A * c - b).squaredNorm();
    };
    const double half = 0.5 / duration; // Hz: half a cycle over the record
    const auto   end  = golden_section(misfit, coarse - half, coarse + half, 40);
    return 0.5 * (end.a + end.b);
  }

  MeasuredRun MeasuredRun::parse(const std::string &text, const std::string &source, double frequency_Hz,
                                 double min_cycles)
  {
    const CsvData data = parse_csv(text, source); // malformed or non-finite cells: file, line, column
    MeasuredRun   run;
    run.source = source;
    for (std::size_t c = 0; c < data.columns.size(); ++c)
      {
        const std::string &name  = data.columns[c];
        const Quantity    *match = nullptr;
        // the expected name, the bare stem, or the stem with another unit
        // (a short token, or token_per_token: time_ms, outlet_pressure_psi)
        static const std::regex unit("[A-Za-z]{1,4}(_per_[A-Za-z]{1,4})?");
        for (const auto &q : known)
          {
            const std::string stem = q.stem;
            if (name == q.column || name == stem ||
                (name.rfind(stem + "_", 0) == 0 && std::regex_match(name.substr(stem.size() + 1), unit)))
              match = &q;
          }
        if (match == nullptr)
          {
            run.ignored_columns.push_back(name);
            continue;
          }
        if (name != match->column)
          throw InputError("'" + source + "', column '" + name + "': " + match->stem + " must be given as '" +
                           match->column + "' (SI units, named in the column)");
        if (run.signals.count(name) > 0)
          throw InputError("'" + source + "': column '" + name + "' appears twice");
        std::vector<double> values;
        for (const auto &row : data.rows)
          values.push_back(row[c]);
        run.signals[name] = std::move(values);
      }
    for (const char *required : {"time_s", "outlet_pressure_Pa"})
      if (!run.has(required))
        throw InputError("'" + source + "': missing column '" + required + "'");
    if (!run.has("current_A") && !run.has("voltage_V"))
      throw InputError("'" + source + "': missing the drive: a column 'current_A' or 'voltage_V'");
    if (data.rows.size() < min_rows)
      throw InputError("'" + source + "': " + std::to_string(data.rows.size()) + " rows, too short a record (at least " +
                       std::to_string(min_rows) + ")");
    run.time_s = run.signals.at("time_s");
    run.signals.erase("time_s");
    for (std::size_t i = 1; i < run.time_s.size(); ++i)
      if (!(run.time_s[i] > run.time_s[i - 1]))
        throw InputError("'" + source + "' data row " + std::to_string(i + 1) + ", column 'time_s': " +
                         format_number(run.time_s[i]) + (run.time_s[i] == run.time_s[i - 1] ? " repeats" : " comes after") +
                         " " + format_number(run.time_s[i - 1]) + ": times must increase strictly");
    if (min_cycles > 0)
      {
        const double f = frequency_Hz > 0 ? frequency_Hz : run.drive_frequency_Hz();
        if (run.duration_s() * f < min_cycles)
          throw InputError("'" + source + "': " + format_number(run.duration_s()) + " s is " +
                           format_number(run.duration_s() * f) + " pumping cycles at " + format_number(f) +
                           " Hz, too short a record (at least " + format_number(min_cycles) + ")");
      }
    return run;
  }

  MeasuredRun MeasuredRun::read(const std::filesystem::path &path, double frequency_Hz, double min_cycles)
  {
    std::ifstream in(path);
    if (!in)
      throw InputError("cannot read '" + path.string() + "'");
    std::stringstream s;
    s << in.rdbuf();
    return parse(s.str(), path.string(), frequency_Hz, min_cycles);
  }

  std::vector<Outlier> MeasuredRun::repair_outliers(double threshold, double frequency_Hz)
  {
    // samples per pumping cycle, for the test of recurrence below (0: none)
    double period = 0;
    if (uniformly_sampled(time_s) && time_s.size() > 1)
      try
        {
          const double f = frequency_Hz > 0 ? frequency_Hz : drive_frequency_Hz();
          period = static_cast<double>(time_s.size() - 1) / (duration_s() * f);
        }
      catch (const InputError &)
        {
          period = 0; // fewer than two cycles: nothing to recur in
        }
    std::vector<Outlier> found;
    for (auto &entry : signals)
      {
        const std::string   &column = entry.first; // not a structured binding: lambdas use x
        std::vector<double> &x      = entry.second;
        if (x.size() < 5)
          continue;
        const double sd = white_noise_sd(x);
        if (!(sd > 0))
          continue;
        const double              limit    = threshold * std::sqrt(1.5) * sd;
        const std::vector<double> original = x; // recurrence is judged on the record as measured
        const auto offset_in = [](const std::vector<double> &y, std::size_t k) {
          return y[k] - 0.5 * (y[k - 1] + y[k + 1]);
        };
        const auto offset = [&](std::size_t k) { return offset_in(x, k); };
        // The same sharp feature at the same phase (one sample either way)
        // in at least half of the record's other cycles: the pump's own (a
        // pressure spike at each valve closing), not an outlier.
        const auto recurs = [&](std::size_t k, double d) {
          if (!(period >= 4))
            return false;
          const double last   = static_cast<double>(x.size()) - 4;
          const auto   c_from = static_cast<long>(std::ceil((3 - static_cast<double>(k)) / period));
          const auto   c_to   = static_cast<long>(std::floor((last - static_cast<double>(k)) / period));
          int          looked = 0, seen = 0;
          for (long c = c_from; c <= c_to; ++c)
            {
              const double at = static_cast<double>(k) + static_cast<double>(c) * period;
              if (c == 0 || at < 3 || at > last)
                continue;
              const auto j = static_cast<std::size_t>(std::lround(at));
              ++looked;
              for (std::size_t i = j - 1; i <= j + 1; ++i)
                {
                  const double e = offset_in(original, i);
                  if (e * d > 0 && std::abs(e) >= 0.5 * std::abs(d))
                    {
                      ++seen;
                      break;
                    }
                }
            }
          return looked > 0 && 2 * seen >= looked;
        };
        for (std::size_t k = 2; k + 2 < x.size(); ++k)
          {
            const double d = offset(k);
            if (!(std::abs(d) > limit))
              continue;
            const double before = offset(k - 1), after = offset(k + 1);
            const auto   partner = [&](double e) {
              return e * d < 0 && std::abs(e) > 0.25 * std::abs(d) && std::abs(e) < 0.75 * std::abs(d);
            };
            if (!partner(before) || !partner(after) || recurs(k, d))
              continue;
            found.push_back({column, k + 1, time_s[k] - time_s.front(), d, d / sd});
            x[k] = 0.5 * (x[k - 1] + x[k + 1]);
          }
      }
    std::sort(found.begin(), found.end(), [](const Outlier &a, const Outlier &b) { return a.time_s < b.time_s; });
    return found;
  }

  const std::vector<std::string> &signal_columns()
  {
    static const std::vector<std::string> columns{"outlet_pressure_Pa",  "chamber_pressure_Pa",
                                                  "outlet_valve_m",      "strain",
                                                  "actuator_position_m", "actuator_velocity_m_per_s"};
    return columns;
  }

  bool uniformly_sampled(const std::vector<double> &t)
  {
    const std::size_t n = t.size();
    if (n < 2)
      return false;
    const double dt = (t.back() - t.front()) / static_cast<double>(n - 1);
    for (std::size_t i = 1; i < n; ++i)
      if (std::abs(t[i] - t[i - 1] - dt) > 0.01 * dt)
        return false;
    return true;
  }
} // namespace rectify::diagnosis
