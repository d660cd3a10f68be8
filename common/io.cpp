#include "common/io.h"

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <ctime>
#include <fcntl.h>
#include <fstream>
#include <sstream>
#include <unistd.h>

#include "common/case_file.h"

namespace rectify
{
  std::string utc_now()
  {
    const std::time_t t = std::time(nullptr);
    char              buf[32];
    std::strftime(buf, sizeof(buf), "%Y-%m-%dT%H:%M:%SZ", std::gmtime(&t));
    return buf;
  }

  void write_file_atomic(const std::filesystem::path &path, const std::string &content)
  {
    const std::filesystem::path tmp = path.string() + ".tmp." + std::to_string(::getpid());
    const auto fail = [&](const std::string &what, int error) {
      std::error_code ec;
      std::filesystem::remove(tmp, ec);
      throw std::runtime_error("cannot write '" + path.string() + "': " + what + std::strerror(error));
    };
    const int fd = ::open(tmp.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0666);
    if (fd < 0)
      fail("", errno);
    for (std::size_t done = 0; done < content.size();)
      {
        const ssize_t n = ::write(fd, content.data() + done, content.size() - done);
        if (n < 0 && errno == EINTR)
          continue;
        if (n <= 0)
          {
            const int error = n < 0 ? errno : EIO;
            ::close(fd);
            fail("", error);
          }
        done += static_cast<std::size_t>(n);
      }
    if (::close(fd) != 0)
      fail("", errno);
    if (::rename(tmp.c_str(), path.c_str()) != 0)
      fail("moving '" + tmp.filename().string() + "' into place: ", errno);
  }

  void write_json(const std::filesystem::path &path, const nlohmann::json &value)
  {
    write_file_atomic(path, value.dump(2) + "\n");
  }

  void ensure_directory(const std::filesystem::path &dir)
  {
    std::error_code ec;
    std::filesystem::create_directories(dir, ec);
    if (ec || !std::filesystem::is_directory(dir))
      throw InputError("cannot create output folder '" + dir.string() + "'" +
                       (ec ? ": " + ec.message() : ""));
  }

  std::string content_hash(const std::string &content)
  {
    std::uint64_t h = 14695981039346656037ull; // FNV-1a, 64 bits
    for (const unsigned char c : content)
      {
        h ^= c;
        h *= 1099511628211ull;
      }
    char buf[17];
    std::snprintf(buf, sizeof(buf), "%016llx", static_cast<unsigned long long>(h));
    return buf;
  }

  std::string file_hash(const std::filesystem::path &path)
  {
    std::ifstream in(path, std::ios::binary);
    if (!in)
      throw InputError("cannot read '" + path.string() + "'");
    std::ostringstream s;
    s << in.rdbuf();
    return content_hash(s.str());
  }

  CsvTable::CsvTable(std::vector<std::string> column_names)
    : names_(std::move(column_names))
  {}

  void CsvTable::add_row(std::span<const double> row)
  {
    if (row.size() != names_.size())
      throw std::logic_error("CsvTable::add_row: row has " + std::to_string(row.size()) +
                             " values for " + std::to_string(names_.size()) + " columns");
    values_.insert(values_.end(), row.begin(), row.end());
    ++n_rows_;
  }

  std::vector<double> CsvTable::column(const std::string &name) const
  {
    for (std::size_t c = 0; c < names_.size(); ++c)
      if (names_[c] == name)
        {
          std::vector<double> out(n_rows_);
          for (std::size_t r = 0; r < n_rows_; ++r)
            out[r] = values_[r * names_.size() + c];
          return out;
        }
    throw std::logic_error("CsvTable: no column '" + name + "'");
  }

  std::string CsvTable::to_string() const
  {
    std::string s;
    for (std::size_t c = 0; c < names_.size(); ++c)
      s += (c ? "," : "") + names_[c];
    s += "\n";
    char buf[32];
    for (std::size_t r = 0; r < n_rows_; ++r)
      {
        for (std::size_t c = 0; c < names_.size(); ++c)
          {
            std::snprintf(buf, sizeof(buf), "%.10g", values_[r * names_.size() + c]);
            if (c)
              s += ',';
            s += buf;
          }
        s += '\n';
      }
    return s;
  }

  void CsvTable::write(const std::filesystem::path &path) const
  {
    write_file_atomic(path, to_string());
  }

  std::size_t CsvData::column_index(const std::string &name, const std::string &file) const
  {
    for (std::size_t c = 0; c < columns.size(); ++c)
      if (columns[c] == name)
        return c;
    std::string have;
    for (const auto &c : columns)
      have += (have.empty() ? "" : ", ") + c;
    throw InputError("'" + file + "': missing column '" + name + "' (columns: " + have + ")");
  }

  namespace
  {
    std::vector<std::string> split(const std::string &line)
    {
      std::vector<std::string> out;
      std::string              cell;
      std::istringstream       in(line);
      while (std::getline(in, cell, ','))
        {
          const auto b = cell.find_first_not_of(" \t\r");
          const auto e = cell.find_last_not_of(" \t\r");
          out.push_back(b == std::string::npos ? "" : cell.substr(b, e - b + 1));
        }
      if (!line.empty() && line.back() == ',')
        out.emplace_back();
      return out;
    }
  } // namespace

  CsvData parse_csv(const std::string &text, const std::string &name)
  {
    CsvData            data;
    std::istringstream in(text);
    std::string        line;
    std::size_t        line_no = 0;
    while (std::getline(in, line))
      {
        ++line_no;
        if (!line.empty() && line.back() == '\r')
          line.pop_back();
        if (line.find_first_not_of(" \t") == std::string::npos)
          continue;
        if (line[line.find_first_not_of(" \t")] == '#')
          {
            data.comments.push_back(line.substr(line.find('#') + 1));
            continue;
          }
        // A data line without its line end is where a copy or a write was
        // cut off, possibly inside a number ("1.2345" -> "1.23" still reads).
        if (in.eof() && !data.columns.empty())
          throw InputError("'" + name + "' line " + std::to_string(line_no) +
                           ": the file ends inside this line (no line end after it): cut off? "
                           "A complete file ends with a newline");
        auto cells = split(line);
        if (data.columns.empty())
          {
            data.columns = cells;
            for (const auto &c : cells)
              if (c.empty())
                throw InputError("'" + name + "' line " + std::to_string(line_no) +
                                 ": empty column name in the header");
            continue;
          }
        if (cells.size() != data.columns.size())
          throw InputError("'" + name + "' line " + std::to_string(line_no) + ": " +
                           std::to_string(cells.size()) + " values for " +
                           std::to_string(data.columns.size()) + " columns");
        std::vector<double> row(cells.size());
        for (std::size_t c = 0; c < cells.size(); ++c)
          {
            const std::string &cell = cells[c];
            char              *end  = nullptr;
            const double       v    = std::strtod(cell.c_str(), &end);
            if (cell.empty() || end != cell.c_str() + cell.size())
              throw InputError("'" + name + "' line " + std::to_string(line_no) +
                               ", column '" + data.columns[c] + "': '" + cell +
                               "' is not a number");
            if (!std::isfinite(v))
              throw InputError("'" + name + "' line " + std::to_string(line_no) +
                               ", column '" + data.columns[c] + "': value " + cell +
                               " is not finite");
            row[c] = v;
          }
        data.rows.push_back(std::move(row));
      }
    if (data.columns.empty())
      throw InputError("'" + name + "' is empty: expected a header row and data");
    return data;
  }

  CsvData read_csv(const std::filesystem::path &path)
  {
    std::ifstream in(path, std::ios::binary);
    if (!in)
      throw InputError("cannot open '" + path.string() + "'");
    std::stringstream buffer;
    buffer << in.rdbuf();
    return parse_csv(buffer.str(), path.string());
  }
  std::string csv_row(std::span<const double> values)
  {
    std::string line;
    char        buf[40];
    for (double v : values)
      {
        std::snprintf(buf, sizeof(buf), "%.17g", v);
        if (!line.empty())
          line += ',';
        line += buf;
      }
    return line;
  }
} // namespace rectify
