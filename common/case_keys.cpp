#include "common/case_keys.h"

namespace rectify
{
  namespace
  {
    std::string quoted(const std::string &text)
    {
      if (text.find_first_of(",\"\n") == std::string::npos)
        return text;
      std::string q = "\"";
      for (const char c : text)
        q += c == '"' ? std::string("\"\"") : std::string(1, c);
      return q + "\"";
    }
  } // namespace

  std::string case_keys_csv(const CaseFile &file)
  {
    std::string csv = "table,key,value,given,range\n";
    for (const auto &k : file.read_keys())
      csv += k.table + "," + k.key + "," + quoted(k.value) + "," + (k.given ? "yes" : "default") + "," +
             quoted(k.range) + "\n";
    return csv;
  }
} // namespace rectify
