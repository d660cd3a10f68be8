#include <cstdio>

#include "app/commands.h"

namespace rectify::app
{
  void add_case_and_out(CLI::App &command, std::string &case_path, std::string &out_dir)
  {
    case_path = reference_case_path().string();
    command.add_option("--case", case_path, "case file (TOML)")->capture_default_str();
    command.add_option("--out", out_dir, "output folder")->required();
  }

  void echo_settings(const std::string                                       &command,
                     const std::vector<std::pair<std::string, std::string>> &settings)
  {
    std::fprintf(stderr, "rectify %s\n", command.c_str());
    for (const auto &[name, value] : settings)
      std::fprintf(stderr, "  %-22s %s\n", name.c_str(), value.c_str());
  }
} // namespace rectify::app

#include "app/main_common.h"
#include "common/case_file.h"

namespace rectify::app
{
  int run_app(CLI::App &app, int argc, char **argv)
  {
    app.require_subcommand(1);
    app.set_version_flag("--version", rectify::version_text(),
                         "Print the version, the source revision and the libraries' versions, then exit");
    try
      {
        app.parse(argc, argv);
      }
    catch (const CLI::ParseError &e)
      {
        return app.exit(e);
      }
    catch (const rectify::InputError &e)
      {
        std::fprintf(stderr, "rectify: error: %s\n", e.what());
        return 2;
      }
    catch (const std::exception &e)
      {
        std::fprintf(stderr, "rectify: failed: %s\n", e.what());
        return 1;
      }
    return 0;
  }
} // namespace rectify::app
