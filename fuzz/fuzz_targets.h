// What each fuzz target does with one input, shared by the libFuzzer targets
// (fuzz_<target>.cpp) and the regression test that replays the seed corpus
// and every input a fuzzer found (tests/test_bad_input.cpp). A parser may
// refuse its input only with InputError: that is caught here. Anything else
// escapes: another exception (std::logic_error below for a value a read
// map must not give), a crash or a sanitizer report is a finding.
#pragma once

#include <cmath>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <stdexcept>
#include <string>
#include <unistd.h>

#include "common/case_file.h"
#include "diagnosis/measured_run.h"
#include "maps/area_map.h"
#include "maps/reed_map.h"
#include "maps/resistance_map.h"
#include "system/drive.h"
#include "system/parameters.h"

namespace rectify::fuzz
{
  inline std::string text(const std::uint8_t *data, std::size_t size)
  {
    return std::string(reinterpret_cast<const char *>(data), size);
  }

  /// The input as a file, for the readers that take a path (one per process).
  inline std::filesystem::path as_file(const std::uint8_t *data, std::size_t size, const char *suffix)
  {
    const std::filesystem::path dir = std::filesystem::exists("/dev/shm") ? "/dev/shm" : "/tmp";
    const auto path = dir / ("rectify-fuzz-" + std::to_string(::getpid()) + suffix);
    std::ofstream(path, std::ios::binary).write(reinterpret_cast<const char *>(data),
                                                 static_cast<std::streamsize>(size));
    return path;
  }

  inline void expect_finite(double v, const char *what)
  {
    if (!std::isfinite(v))
      throw std::logic_error(std::string("non-finite ") + what + " from a map that read");
  }

  /// The case file: TOML, then every system table's keys read and
  /// range-checked (map-set folders not opened).
  inline void case_file(const std::uint8_t *data, std::size_t size)
  {
    try
      {
        const auto file = CaseFile::parse(text(data, size), "fuzz.toml", "/nonexistent");
        (void)system::SystemParameters::from_case(file, false).to_json();
      }
    catch (const InputError &)
      {
      }
  }

  /// The measured-run CSV (diagnose --data), then the outlier search every
  /// diagnosis runs on it.
  inline void measured_run(const std::uint8_t *data, std::size_t size)
  {
    if (size > 200000)
      return;
    try
      {
        auto run = diagnosis::MeasuredRun::parse(text(data, size), "fuzz.csv");
        (void)run.repair_outliers();
      }
    catch (const InputError &)
      {
      }
  }

  /// The maps: the first byte picks R(x) (with each interpolation), A_eff(x)
  /// or the reed map; a map that reads is evaluated across and beyond its range.
  inline void maps(const std::uint8_t *data, std::size_t size)
  {
    using namespace rectify::maps;
    if (size < 1 || size > 100000)
      return;
    const unsigned which = data[0] % 6;
    const auto     path  = as_file(data + 1, size - 1, ".csv");
    struct Remove
    {
      std::filesystem::path p;
      ~Remove() { std::filesystem::remove(p); }
    } remove{path};
    try
      {
        if (which < 4)
          {
            const Interpolation kinds[] = {Interpolation::monotone_cubic, Interpolation::log_linear,
                                           Interpolation::linear, Interpolation::log_log};
            const auto map = ResistanceMap::read(path, kinds[which]);
            for (double x : {-1e-6, 0.0, 1e-9, 1e-6, 2e-5, 1e-4, 1e-3, 1.0})
              {
                const auto v = map.evaluate(x);
                expect_finite(v.resistance, "R");
                expect_finite(v.slope, "dR/dx");
              }
          }
        else if (which == 4)
          {
            const auto map = AreaMap::read(path);
            for (double x : {-1e-6, 0.0, 1e-9, 1e-6, 2e-5, 1e-4, 1e-3, 1.0})
              {
                const auto v = map.evaluate(x);
                expect_finite(v.area, "A_eff");
                expect_finite(v.slope, "dA_eff/dx");
              }
          }
        else
          {
            const auto map = ReedMap::read(path);
            for (double t : {1e-5, 1e-4, 1.5e-4, 2.5e-4, 1e-3})
              try
                {
                  const auto p = map.at(t, "effective_mass_eq321_kg", "fuzz");
                  expect_finite(p.stiffness_N_per_m, "k_r");
                  expect_finite(p.mass_kg, "m_r");
                }
              catch (const InputError &)
                {
                }
          }
      }
    catch (const InputError &)
      {
      }
  }

  /// The drive-current CSV (a case's [drive] waveform), looked up inside
  /// the times it covers.
  inline void drive(const std::uint8_t *data, std::size_t size)
  {
    if (size > 100000)
      return;
    const auto path = as_file(data, size, ".csv");
    struct Remove
    {
      std::filesystem::path p;
      ~Remove() { std::filesystem::remove(p); }
    } remove{path};
    try
      {
        const auto d = system::Drive::from_csv(path, 100.0);
        for (double t : {0.0, 1e-4, 1e-3, 0.01, 0.1, 1.0})
          {
            try
              {
                d.check_covers(t);
              }
            catch (const InputError &)
              {
                continue;
              }
            expect_finite(d.value(t), "drive value");
          }
      }
    catch (const InputError &)
      {
      }
  }
} // namespace rectify::fuzz
