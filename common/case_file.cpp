#include "common/case_file.h"

#include <algorithm>
#include <cstdlib>

#include <charconv>
#include <cmath>
#include <fstream>
#include <sstream>
#include <toml.hpp>

namespace rectify
{
  struct CaseFile::Impl
  {
    toml::value root;
  };

  std::string format_number(double value)
  {
    if (std::isnan(value))
      return "nan";
    if (std::isinf(value))
      return value > 0 ? "inf" : "-inf";
    char buffer[64];
    auto [end, ec] = std::to_chars(buffer, buffer + sizeof(buffer), value);
    (void)ec;
    return std::string(buffer, end);
  }

  bool Bounds::contains(double value) const
  {
    if (!std::isfinite(value))
      return false;
    const bool above = min_inclusive ? value >= min : value > min;
    const bool below = max_inclusive ? value <= max : value < max;
    return above && below;
  }

  std::string Bounds::describe() const
  {
    const double big = std::numeric_limits<double>::max();
    std::ostringstream s;
    if (min > -big && max < big)
      s << "in " << (min_inclusive ? "[" : "(") << format_number(min) << ", "
        << format_number(max) << (max_inclusive ? "]" : ")");
    else if (min > -big)
      s << (min_inclusive ? ">= " : "> ") << format_number(min);
    else if (max < big)
      s << (max_inclusive ? "<= " : "< ") << format_number(max);
    else
      s << "finite";
    return s.str();
  }

  CaseFile::CaseFile(std::shared_ptr<const Impl> impl)
    : impl_(std::move(impl))
  {}

  CaseFile CaseFile::load(const std::filesystem::path &path)
  {
    std::ifstream in(path, std::ios::binary);
    if (!in)
      throw InputError("cannot open case file '" + path.string() + "'");
    std::stringstream buffer;
    buffer << in.rdbuf();
    return parse(buffer.str(), path.string(), path.parent_path());
  }

  namespace
  {
    /// The first byte where `text` is not UTF-8 (overlong forms, surrogates
    /// and code points above U+10FFFF included), or npos.
    std::size_t invalid_utf8(const std::string &text)
    {
      const auto        *b = reinterpret_cast<const unsigned char *>(text.data());
      const std::size_t  n = text.size();
      for (std::size_t i = 0; i < n;)
        {
          const unsigned c = b[i];
          std::size_t    len;
          unsigned       cp;
          if (c < 0x80)
            {
              ++i;
              continue;
            }
          if (c >= 0xC2 && c <= 0xDF)
            len = 2, cp = c & 0x1F;
          else if (c >= 0xE0 && c <= 0xEF)
            len = 3, cp = c & 0x0F;
          else if (c >= 0xF0 && c <= 0xF4)
            len = 4, cp = c & 0x07;
          else
            return i;
          if (i + len > n)
            return i;
          for (std::size_t k = 1; k < len; ++k)
            {
              if ((b[i + k] & 0xC0) != 0x80)
                return i;
              cp = (cp << 6) | (b[i + k] & 0x3F);
            }
          if ((len == 3 && (cp < 0x800 || (cp >= 0xD800 && cp <= 0xDFFF))) ||
              (len == 4 && (cp < 0x10000 || cp > 0x10FFFF)))
            return i;
          i += len;
        }
      return std::string::npos;
    }
  } // namespace

  CaseFile CaseFile::parse(const std::string &text, const std::string &name,
                           const std::filesystem::path &base_dir)
  {
    // TOML is UTF-8. Checked here, not left to toml11: its 3.7 reads past
    // the end of its buffer reporting bad UTF-8 in a '...' string (found by
    // fuzz/fuzz_case_file.cpp).
    if (const auto at = invalid_utf8(text); at != std::string::npos)
      {
        const auto        line  = 1 + std::count(text.begin(), text.begin() + static_cast<std::ptrdiff_t>(at), '\n');
        const std::size_t start = at == 0 ? 0 : text.find_last_of('\n', at - 1) + 1; // npos + 1 = 0
        const std::size_t col   = at - start;
        throw InputError("case file '" + name + "' is not valid TOML: line " + std::to_string(line) + ", byte " +
                         std::to_string(col + 1) + " is not UTF-8 (a TOML file is UTF-8 text)");
      }
    auto impl = std::make_shared<Impl>();
    try
      {
        std::istringstream in(text);
        impl->root = toml::parse(in, name);
      }
    catch (const toml::exception &e) // syntax_error and the rest of toml11's
      {
        throw InputError("case file '" + name + "' is not valid TOML:\n" + e.what());
      }
    if (!impl->root.is_table())
      throw InputError("case file '" + name + "' does not hold a TOML table");
    CaseFile file(impl);
    file.name_     = name;
    file.base_dir_ = base_dir.empty() ? std::filesystem::path(".") : base_dir;
    return file;
  }

  std::filesystem::path CaseFile::resolve(const std::string &path_in_file) const
  {
    const std::filesystem::path p(path_in_file);
    return p.is_absolute() ? p : base_dir_ / p;
  }

  namespace
  {
    /// "port#2" -> ("port", 2); any other name -> (name, 0).
    std::pair<std::string, std::size_t> split_entry(const std::string &table)
    {
      const auto hash = table.find('#');
      if (hash == std::string::npos)
        return {table, 0};
      return {table.substr(0, hash), static_cast<std::size_t>(std::stoul(table.substr(hash + 1)))};
    }

    /// The table `table` names: a [table], or entry i of an array of tables for "name#i".
    const toml::value *find_table(const toml::value &root, const std::string &table)
    {
      const auto &top           = root.as_table();
      const auto [name, entry] = split_entry(table);
      const auto  t             = top.find(name);
      if (t == top.end())
        return nullptr;
      if (entry == 0)
        return t->second.is_table() ? &t->second : nullptr;
      if (!t->second.is_array() || entry > t->second.as_array().size())
        return nullptr;
      const auto &e = t->second.as_array()[entry - 1];
      return e.is_table() ? &e : nullptr;
    }

    const toml::value *find(const toml::value &root, const std::string &table,
                            const std::string &key)
    {
      const toml::value *t = find_table(root, table);
      if (t == nullptr)
        return nullptr;
      const auto &inner = t->as_table();
      const auto  k     = inner.find(key);
      return k == inner.end() ? nullptr : &k->second;
    }
  } // namespace

  std::string CaseFile::where(const std::string &table, const std::string &key) const
  {
    const auto [name, entry] = split_entry(table);
    if (entry > 0)
      return "case file '" + name_ + "' [[" + name + "]] #" + std::to_string(entry) + " " + key;
    return "case file '" + name_ + "' [" + table + "] " + key;
  }

  std::size_t CaseFile::table_count(const std::string &array_name) const
  {
    const auto &top = impl_->root.as_table();
    const auto  t   = top.find(array_name);
    if (t == top.end())
      return 0;
    if (!t->second.is_array())
      throw InputError("case file '" + name_ + "': '" + array_name + "' must be written [[" + array_name +
                       "]], one such table per entry");
    for (std::size_t i = 0; i < t->second.as_array().size(); ++i)
      if (!t->second.as_array()[i].is_table())
        throw InputError("case file '" + name_ + "': '" + array_name + "' entry " + std::to_string(i + 1) +
                         " is not a table; write [[" + array_name + "]]");
    return t->second.as_array().size();
  }

  namespace
  {

    std::string line_of(const toml::value &v)
    {
      const auto loc = v.location();
      return loc.line() > 0 ? " (line " + std::to_string(loc.line()) + ")" : "";
    }
  } // namespace

  bool CaseFile::has(const std::string &table, const std::string &key) const
  {
    return find(impl_->root, table, key) != nullptr;
  }

  std::vector<std::string> CaseFile::keys(const std::string &table) const
  {
    std::vector<std::pair<std::size_t, std::string>> found;
    if (const toml::value *t = find_table(impl_->root, table))
      for (const auto &[key, value] : t->as_table())
        found.emplace_back(value.location().line(), key);
    std::sort(found.begin(), found.end());
    std::vector<std::string> out;
    for (auto &[line, key] : found)
      out.push_back(std::move(key));
    return out;
  }

  void CaseFile::declare(const std::string &table, const std::string &key) const
  {
    known_.insert(table + "." + key);
  }

  double CaseFile::real(const std::string &table, const std::string &key,
                        double default_value, const Bounds &bounds) const
  {
    declare(table, key);
    const toml::value *v = find(impl_->root, table, key);
    double             value = default_value;
    if (v != nullptr)
      {
        if (v->is_floating())
          value = v->as_floating();
        else if (v->is_integer())
          value = static_cast<double>(v->as_integer());
        else
          throw InputError(where(table, key) + line_of(*v) +
                           ": expected a number, got " + toml::format(*v));
      }
    if (!bounds.contains(value))
      throw InputError(where(table, key) + (v ? line_of(*v) : " (default)") + " = " +
                       format_number(value) + ": must be " + bounds.describe());
    record(table, key, format_number(value), bounds.describe());
    real_bounds_[table + "." + key] = bounds;
    return value;
  }

  const Bounds *CaseFile::bounds_read(const std::string &table, const std::string &key) const
  {
    const auto it = real_bounds_.find(table + "." + key);
    return it == real_bounds_.end() ? nullptr : &it->second;
  }

  std::vector<double> CaseFile::reals(const std::string &table, const std::string &key,
                                      const std::vector<double> &default_value,
                                      const Bounds              &bounds) const
  {
    declare(table, key);
    const toml::value  *v      = find(impl_->root, table, key);
    std::vector<double> values = default_value;
    if (v != nullptr)
      {
        if (!v->is_array())
          throw InputError(where(table, key) + line_of(*v) + ": expected an array of numbers, got " +
                           toml::format(*v));
        values.clear();
        for (const auto &e : v->as_array())
          {
            if (e.is_floating())
              values.push_back(e.as_floating());
            else if (e.is_integer())
              values.push_back(static_cast<double>(e.as_integer()));
            else
              throw InputError(where(table, key) + line_of(*v) + ": expected numbers, got " +
                               toml::format(e));
          }
        if (values.empty())
          throw InputError(where(table, key) + line_of(*v) + ": the array is empty");
      }
    for (std::size_t i = 0; i < values.size(); ++i)
      if (!bounds.contains(values[i]))
        throw InputError(where(table, key) + (v ? line_of(*v) : " (default)") + ", entry " +
                         std::to_string(i + 1) + " = " + format_number(values[i]) + ": must be " +
                         bounds.describe());
    std::string list;
    for (const double x : values)
      list += (list.empty() ? "" : " ") + format_number(x);
    record(table, key, "[" + list + "]", "each " + bounds.describe());
    return values;
  }

  std::vector<std::array<double, 2>> CaseFile::points(const std::string &table, const std::string &key,
                                                      const Bounds &bounds) const
  {
    declare(table, key);
    const toml::value                 *v = find(impl_->root, table, key);
    std::vector<std::array<double, 2>> out;
    if (v == nullptr)
      return out;
    const auto number = [&](const toml::value &e, std::size_t i) {
      if (e.is_floating())
        return e.as_floating();
      if (e.is_integer())
        return static_cast<double>(e.as_integer());
      throw InputError(where(table, key) + line_of(*v) + ", point " + std::to_string(i + 1) +
                       ": expected numbers, got " + toml::format(e));
    };
    if (!v->is_array() || v->as_array().empty())
      throw InputError(where(table, key) + line_of(*v) + ": expected a list of [x, y] points, got " +
                       toml::format(*v));
    std::string list;
    for (std::size_t i = 0; i < v->as_array().size(); ++i)
      {
        const auto &e = v->as_array()[i];
        if (!e.is_array() || e.as_array().size() != 2)
          throw InputError(where(table, key) + line_of(*v) + ", point " + std::to_string(i + 1) +
                           ": expected [x, y], got " + toml::format(e));
        const std::array<double, 2> p{number(e.as_array()[0], i), number(e.as_array()[1], i)};
        for (const double c : p)
          if (!bounds.contains(c))
            throw InputError(where(table, key) + line_of(*v) + ", point " + std::to_string(i + 1) + " = [" +
                             format_number(p[0]) + ", " + format_number(p[1]) + "]: each coordinate must be " +
                             bounds.describe());
        out.push_back(p);
        list += (list.empty() ? "[" : " [") + format_number(p[0]) + ", " + format_number(p[1]) + "]";
      }
    record(table, key, "[" + list + "]", "points, each coordinate " + bounds.describe());
    return out;
  }

  long CaseFile::integer(const std::string &table, const std::string &key, long default_value,
                         long min, long max) const
  {
    declare(table, key);
    const toml::value *v     = find(impl_->root, table, key);
    long               value = default_value;
    if (v != nullptr)
      {
        if (!v->is_integer())
          throw InputError(where(table, key) + line_of(*v) + ": expected a whole number, got " +
                           toml::format(*v));
        value = static_cast<long>(v->as_integer());
      }
    if (value < min || value > max)
      throw InputError(where(table, key) + (v ? line_of(*v) : " (default)") + " = " +
                       std::to_string(value) + ": must be in [" + std::to_string(min) + ", " +
                       std::to_string(max) + "]");
    record(table, key, std::to_string(value), "whole number in [" + std::to_string(min) + ", " +
                                                std::to_string(max) + "]");
    return value;
  }

  std::string CaseFile::text(const std::string &table, const std::string &key,
                             const std::string              &default_value,
                             const std::vector<std::string> &allowed) const
  {
    declare(table, key);
    const toml::value *v     = find(impl_->root, table, key);
    std::string        value = default_value;
    if (v != nullptr)
      {
        if (!v->is_string())
          throw InputError(where(table, key) + line_of(*v) + ": expected a string, got " +
                           toml::format(*v));
        value = v->as_string().str;
      }
    if (!allowed.empty())
      {
        bool ok = false;
        for (const auto &a : allowed)
          ok = ok || a == value;
        if (!ok)
          {
            std::string list;
            for (const auto &a : allowed)
              list += (list.empty() ? "" : ", ") + ("'" + a + "'");
            throw InputError(where(table, key) + " = '" + value + "': must be one of " + list);
          }
      }
    std::string range = "text";
    if (!allowed.empty())
      {
        range = "one of";
        for (const auto &a : allowed)
          range += " '" + a + "'";
      }
    record(table, key, value, range);
    return value;
  }

  void CaseFile::record(const std::string &table, const std::string &key, const std::string &value,
                        const std::string &range) const
  {
    read_[table + "." + key] = {table, key, value, range, has(table, key)};
  }

  std::vector<CaseFile::KeyRecord> CaseFile::read_keys() const
  {
    std::vector<KeyRecord> out;
    for (const auto &[name, r] : read_)
      out.push_back(r);
    return out;
  }

  void CaseFile::check_all_keys_known() const
  {
    const auto check_table = [&](const std::string &table, const toml::value &value, const std::string &shown) {
      bool any_known = false;
      for (const auto &k : known_)
        any_known = any_known || k.rfind(table + ".", 0) == 0;
      if (!any_known)
        throw InputError("case file '" + name_ + "': unknown table " + shown + line_of(value));
      for (const auto &[key, inner] : value.as_table())
        if (known_.count(table + "." + key) == 0)
          throw InputError(where(table, key) + line_of(inner) +
                           ": unknown key (check its spelling and unit suffix)");
    };
    for (const auto &[table, value] : impl_->root.as_table())
      {
        if (value.is_array() && !value.as_array().empty() && value.as_array().front().is_table())
          {
            for (std::size_t i = 0; i < value.as_array().size(); ++i)
              if (value.as_array()[i].is_table())
                check_table(table + "#" + std::to_string(i + 1), value.as_array()[i], "[[" + table + "]]");
            continue;
          }
        if (!value.is_table())
          throw InputError("case file '" + name_ + "': '" + table + "'" + line_of(value) +
                           " must be a [table]; top-level keys are not used");
        check_table(table, value, "[" + table + "]");
      }
  }

  std::vector<std::filesystem::path> reference_case_search_path()
  {
    std::vector<std::filesystem::path> places;
    if (const char *data = std::getenv("RECTIFY_DATA_DIR"); data != nullptr && *data != '\0')
      places.push_back(std::filesystem::path(data) / "cases" / "reference.toml");
    std::error_code ec;
    const auto      exe = std::filesystem::read_symlink("/proc/self/exe", ec);
    if (!ec) // installed: PREFIX/bin/rectify and PREFIX/share/rectify/cases/reference.toml
      places.push_back(exe.parent_path().parent_path() / "share" / "rectify" / "cases" / "reference.toml");
    places.push_back(std::filesystem::path(RECTIFY_SOURCE_DIR) / "cases" / "reference.toml"); // a build-tree run
    return places;
  }

  std::filesystem::path reference_case_path()
  {
    const auto places = reference_case_search_path();
    for (const auto &p : places)
      if (std::filesystem::is_regular_file(p))
        return p;
    return places.front(); // none exists: the first place, which the error will name
  }
} // namespace rectify
