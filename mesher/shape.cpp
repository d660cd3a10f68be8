#include "mesher/shape.h"

#include <algorithm>
#include <cmath>

#include "common/case_file.h"
#include "common/io.h"

namespace rectify::mesher
{
  ReedShape ReedShape::beam(double length_m, double load_at_m)
  {
    ReedShape shape;
    shape.name_    = "beam";
    shape.length_  = length_m;
    shape.load_at_ = load_at_m;
    return shape;
  }

  ReedShape ReedShape::table(std::vector<double> s, std::vector<double> phi, double length_m,
                             const std::string &source)
  {
    const auto fail = [&](std::size_t row, const std::string &why) {
      throw InputError(source + ": reed shape table, data row " + std::to_string(row + 1) +
                       " (s_m = " + format_number(s[row]) + ", phi = " + format_number(phi[row]) +
                       "): " + why);
    };
    if (s.size() < 2 || s.size() != phi.size())
      throw InputError(source + ": a reed shape table needs at least two rows of s_m and phi");
    if (std::abs(s.front()) > 1e-9 * length_m)
      fail(0, "the table must start at the clamp line, s_m = 0");
    if (std::abs(phi.front()) > 1e-9 * std::max(1.0, std::abs(phi.back())))
      fail(0, "the deflection must be zero at the clamp line");
    for (std::size_t i = 1; i < s.size(); ++i)
      {
        if (!(s[i] > s[i - 1]))
          fail(i, "s_m must increase strictly from the clamp");
        if (phi[i] < phi[i - 1])
          fail(i, "the deflection is not monotone from the clamp (it decreases here)");
      }
    if (std::abs(s.back() - length_m) > 1e-6 * length_m)
      fail(s.size() - 1, "the table must end at the reed's tip, s_m = reed_length_m = " +
                           format_number(length_m));
    if (!(phi.back() > 0))
      fail(s.size() - 1, "the tip deflection must be positive");
    const double tip = phi.back();
    for (double &p : phi)
      p /= tip;
    s.front() = 0.0;
    s.back()  = length_m;
    ReedShape shape;
    shape.name_   = "table";
    shape.length_ = length_m;
    shape.s_      = std::move(s);
    shape.phi_    = std::move(phi);
    return shape;
  }

  ReedShape ReedShape::from_csv(const std::filesystem::path &path, double length_m)
  {
    const CsvData     data = read_csv(path);
    const std::string name = path.string();
    const std::size_t is   = data.column_index("s_m", name);
    const std::size_t ip   = data.column_index("phi", name);
    std::vector<double> s, phi;
    for (const auto &row : data.rows)
      {
        s.push_back(row[is]);
        phi.push_back(row[ip]);
      }
    return table(std::move(s), std::move(phi), length_m, name);
  }

  double ReedShape::operator()(double s) const
  {
    s = std::clamp(s, 0.0, length_);
    if (s_.empty())
      {
        const double a = load_at_, L = length_;
        if (s <= a)
          return s * s * (3 * a - s) / (a * a * (3 * L - a));
        return (3 * s - a) / (3 * L - a);
      }
    const auto   it = std::upper_bound(s_.begin(), s_.end(), s);
    const size_t j  = std::clamp<std::size_t>(it - s_.begin(), 1, s_.size() - 1);
    const double w  = (s - s_[j - 1]) / (s_[j] - s_[j - 1]);
    return (1 - w) * phi_[j - 1] + w * phi_[j];
  }

  SampledShape::SampledShape(const ReedShape &shape, double spacing, const std::vector<double> &avoid)
  {
    const double L = shape.length();
    const auto   n = static_cast<std::size_t>(std::max(2.0, std::ceil(L / spacing - 1e-9)));
    const double h = L / static_cast<double>(n);
    for (std::size_t j = 0; j <= n; ++j)
      {
        double s = j == n ? L : L * static_cast<double>(j) / static_cast<double>(n);
        // An inner station closer than 0.3 h to an avoided point moves to 0.3 h
        // from it, away from it (stations stay at least 0.4 h apart).
        for (double a : avoid)
          if (j > 0 && j < n && std::abs(s - a) < 0.3 * h)
            s = a + (s >= a ? 0.3 : -0.3) * h;
        s_.push_back(s);
        phi_.push_back(shape(s));
      }
    for (std::size_t j = 1; j <= n; ++j)
      for (int k = 1; k < 50; ++k)
        {
          const double s = s_[j - 1] + (s_[j] - s_[j - 1]) * k / 50.0;
          max_error_     = std::max(max_error_, std::abs(shape(s) - (*this)(s)));
        }
  }

  double SampledShape::operator()(double s) const
  {
    if (s >= s_.back())
      return phi_.back();
    if (s <= 0)
      return phi_.front();
    const auto   it = std::upper_bound(s_.begin(), s_.end(), s);
    const size_t j  = static_cast<std::size_t>(it - s_.begin());
    const double w  = (s - s_[j - 1]) / (s_[j] - s_[j - 1]);
    return (1 - w) * phi_[j - 1] + w * phi_[j];
  }

  double SampledShape::integral_to_station(std::size_t j) const
  {
    double sum = 0;
    for (std::size_t i = 1; i <= j; ++i)
      sum += 0.5 * (phi_[i - 1] + phi_[i]) * (s_[i] - s_[i - 1]);
    return sum;
  }
} // namespace rectify::mesher
