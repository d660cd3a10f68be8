// A struct's real case keys, declared once as a table: each key's name, its
// field and admissible range, and whether [uncertain] may name it. The
// table drives their reading (read_reals), their access by name
// (find_real: SystemParameters::real_field) and their place in summaries
// (put_reals: to_json). Text and integer keys, and keys read under a
// condition, are read by the struct's own from_case.
#pragma once

#include <algorithm>
#include <cstddef>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "common/case_file.h"

namespace rectify
{
  template <typename S>
  struct RealKey
  {
    const char *key;
    double S::*field;
    Bounds      bounds;
    bool        uncertain = true; ///< may be named in [uncertain] (real_field)
  };
  template <typename S>
  using RealKeys = std::vector<RealKey<S>>;

  /// Reads keys [first, last) of `table` into p, each within its range
  /// (the struct's default where the file leaves it out).
  template <typename S>
  void read_reals(const CaseFile &f, const std::string &table, const RealKeys<S> &keys, S &p, std::size_t first = 0,
                  std::size_t last = std::size_t(-1))
  {
    for (std::size_t i = first; i < std::min(last, keys.size()); ++i)
      p.*keys[i].field = f.real(table, keys[i].key, p.*keys[i].field, keys[i].bounds);
  }

  /// Every key's value into j (a summary's table).
  template <typename S>
  void put_reals(nlohmann::json &j, const RealKeys<S> &keys, const S &p)
  {
    for (const auto &k : keys)
      j[k.key] = p.*k.field;
  }

  /// The field of the key that [uncertain] may name, or nullptr.
  template <typename S>
  double *find_real(const RealKeys<S> &keys, S &p, const std::string &key)
  {
    for (const auto &k : keys)
      if (k.uncertain && key == k.key)
        return &(p.*k.field);
    return nullptr;
  }
} // namespace rectify
