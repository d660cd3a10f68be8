#include "maps/metadata.h"

#include "common/case_file.h"

namespace rectify::maps
{
  nlohmann::json read_metadata(const CsvData &csv, const std::string &what)
  {
    nlohmann::json meta = nlohmann::json::object();
    for (const auto &c : csv.comments)
      if (const auto pos = c.find("meta:"); pos != std::string::npos)
        {
          try
            {
              meta = nlohmann::json::parse(c.substr(pos + 5));
            }
          catch (const nlohmann::json::exception &e)
            {
              throw InputError(what + ": the '# meta:' line is not valid JSON: " + e.what());
            }
        }
    return meta;
  }
} // namespace rectify::maps
