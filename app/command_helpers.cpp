#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <system_error>
#include <unistd.h>

#include "app/commands.h"
#include "app/main_common.h"
#include "common/case_file.h"
#include "system/integrator.h"

namespace rectify::app
{
  std::string check_output_folder(const std::filesystem::path &folder)
  {
    namespace fs = std::filesystem;
    std::error_code ec;
    if (folder.empty())
      return "empty output folder name";
    if (fs::exists(folder, ec) && !fs::is_directory(folder, ec))
      return "'" + folder.string() + "' exists and is not a folder";
    // Try it: write and remove a file in the folder, or in the nearest
    // folder above it that exists (where it would be made), so that a
    // folder that cannot be written is found before any work. Nothing is
    // created that stays, and nothing another process (an MPI rank with the
    // same --out) could trip over.
    fs::path existing = fs::absolute(folder, ec);
    while (!existing.empty() && !fs::exists(existing, ec) && existing != existing.parent_path())
      existing = existing.parent_path();
    if (!fs::is_directory(existing, ec))
      return "cannot create output folder '" + folder.string() + "': '" + existing.string() +
             "' is not a folder";
    const fs::path probe = existing / (".rectify-write-test-" + std::to_string(::getpid()));
    bool           ok    = static_cast<bool>(std::ofstream(probe) << "x");
    fs::remove(probe, ec);
    if (!ok)
      return existing == fs::absolute(folder, ec) ?
               "cannot write into output folder '" + folder.string() + "'" :
               "cannot create output folder '" + folder.string() + "': '" + existing.string() +
                 "' cannot be written";
    return {};
  }

  void add_case_and_out(CLI::App &command, std::string &case_path, std::string &out_dir)
  {
    case_path = reference_case_path().string();
    command.add_option("--case", case_path, "case file (TOML)")->capture_default_str();
    command.add_option("--out", out_dir, "output folder")
      ->required()
      ->check(CLI::Validator([](std::string &text) { return check_output_folder(text); }, "", "writable"));
  }

  CLI::Validator auto_or_range(double lower, double upper, const std::string &name)
  {
    return CLI::Validator(
      [=](std::string &text) -> std::string {
        if (text == "auto")
          return {};
        char        *end = nullptr;
        const double v   = std::strtod(text.c_str(), &end);
        if (text.empty() || *end != '\0' || !(v >= lower && v <= upper))
          return "'" + text + "' is neither 'auto' nor a number in [" + format_number(lower) + ", " +
                 format_number(upper) + "]";
        return {};
      },
      "auto|" + format_number(lower) + ".." + format_number(upper), name);
  }

  void echo_settings(const std::string                                       &command,
                     const std::vector<std::pair<std::string, std::string>> &settings)
  {
    std::fprintf(stderr, "rectify %s\n", command.c_str());
    for (const auto &[name, value] : settings)
      std::fprintf(stderr, "  %-22s %s\n", name.c_str(), value.c_str());
  }
} // namespace rectify::app

namespace rectify::app
{
  namespace
  {
    /// A whole number >= 0 (CLI11 2.1 would read "-3" into an unsigned
    /// option as 18446744073709551613).
    const CLI::Validator whole_number(
      [](std::string &text) -> std::string {
        std::size_t i = text.size() > 0 && text[0] == '+' ? 1 : 0;
        if (i == text.size())
          return "'" + text + "' is not a whole number >= 0";
        for (; i < text.size(); ++i)
          if (text[i] < '0' || text[i] > '9')
            return "'" + text + "' is not a whole number >= 0";
        return {};
      },
      "", "whole number");

    /// A finite number: NaN and infinities are refused (and so can never
    /// be confused with an option "not given").
    const CLI::Validator finite_number(
      [](std::string &text) -> std::string {
        char *end = nullptr;
        errno     = 0;
        const double v = std::strtod(text.c_str(), &end);
        if (text.empty() || end == text.c_str() || *end != '\0')
          return "'" + text + "' is not a number";
        if (!std::isfinite(v) || errno == ERANGE)
          return "'" + text + "' is not a finite number";
        return {};
      },
      "", "finite number");

    /// Every numeric option of every command gets its type's check.
    void add_number_checks(CLI::App &app)
    {
      for (CLI::Option *option : app.get_options())
        {
          const std::string type = option->get_type_name();
          if (type.rfind("UINT", 0) == 0)
            option->check(whole_number);
          else if (type.rfind("FLOAT", 0) == 0 || type.rfind("INT", 0) == 0)
            option->check(finite_number);
        }
      for (CLI::App *sub : app.get_subcommands([](CLI::App *) { return true; }))
        add_number_checks(*sub);
    }
  } // namespace

  int run_app(CLI::App &app, int argc, char **argv)
  {
    app.require_subcommand(1);
    app.set_version_flag("--version", rectify::version_text() + "CVODE loaded from " + system::cvode_library() + "\n",
                         "Print the version, the source revision and the libraries' versions, then exit");
    add_number_checks(app);
    try
      {
        // A command that does not exist, named (CLI11 would say "A subcommand is required").
        if (argc > 1 && argv[1][0] != '-')
          {
            bool known = false;
            std::string names;
            for (CLI::App *sub : app.get_subcommands([](CLI::App *) { return true; }))
              {
                known = known || sub->get_name() == argv[1];
                names += (names.empty() ? "" : ", ") + sub->get_name();
              }
            if (!known)
              throw InputError("unknown command '" + std::string(argv[1]) + "' (commands: " + names + ")");
          }
        app.parse(argc, argv);
      }
    catch (const CLI::ParseError &e)
      {
        if (e.get_exit_code() == 0) // --help, --version
          return app.exit(e);
        // Bad options are bad input: exit code 2, as for a bad case file.
        std::fprintf(stderr, "rectify: error: %s\nRun with --help for more information.\n", e.what());
        return 2;
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
