#include "common/checkpoint.h"

#include <fstream>

#include "common/case_file.h"
#include "common/io.h"

namespace rectify
{
  Checkpoint::Checkpoint(const std::filesystem::path &dir, const std::string &name,
                         const nlohmann::json &fingerprint, const std::string &header)
  {
    const auto csv  = dir / (name + ".csv");
    const auto json = dir / (name + ".json");
    if (std::filesystem::exists(csv))
      {
        nlohmann::json old;
        try
          {
            std::ifstream in(json);
            old = nlohmann::json::parse(in);
          }
        catch (const std::exception &)
          {
            old = nullptr;
          }
        if (old != fingerprint)
          throw InputError("'" + dir.string() + "' holds a partial run with other settings (" +
                           json.string() + "); choose another --out, or delete its " + name +
                           ".* files");
        std::ifstream in(csv);
        std::string   line;
        bool          first = true;
        while (std::getline(in, line))
          {
            const bool complete = !in.eof(); // a last line without newline was cut off
            if (first)
              {
                first = false;
                if (line == header)
                  continue;
              }
            if (complete && !line.empty())
              rows_.push_back(line);
          }
      }
    else
      {
        write_json(json, fingerprint);
        write_file_atomic(csv, header + "\n");
      }
    file_ = std::fopen(csv.c_str(), "a");
    if (!file_)
      throw std::runtime_error("cannot append to '" + csv.string() + "'");
  }

  Checkpoint::~Checkpoint()
  {
    if (file_)
      std::fclose(file_);
  }

  void Checkpoint::append(const std::string &row)
  {
    std::lock_guard<std::mutex> lock(mutex_);
    const std::string           line = row + "\n";
    std::fwrite(line.data(), 1, line.size(), file_);
    std::fflush(file_);
  }
} // namespace rectify
