#include "app/fe_commands.h"

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <unistd.h>

namespace rectify::app
{
  const std::vector<std::pair<std::string, std::string>> &fe_commands()
  {
    static const std::vector<std::pair<std::string, std::string>> c{
      {"mesh", "Tetrahedral mesh of the valve's fluid domain at one tip opening (TetGen, CGAL)"},
      {"stokes", "Stokes flow through the valve at one opening: R, the reed's force, A_eff (deal.II)"},
      {"map-resistance", "R(x) and A_eff(x) over the openings, adaptive in the opening, resumable"},
      {"stiffness", "Linear elasticity of the reed: k_r, deflected shape, modes (deal.II)"},
      {"map-stiffness", "Stiffness and modes over a range of reed thicknesses"},
      {"design", "One valve design's map set: every FE map the system model reads"},
      {"whatif", "Design what-ifs: many designs' map sets and the system's answer, one MPI batch"}};
    return c;
  }

  void register_fe_command_stubs(CLI::App &app)
  {
    for (const auto &[name, description] : fe_commands())
      app.add_subcommand(name, description + " [rectify-fe]")->allow_extras();
  }

  namespace
  {
    /// This executable's folder (/proc/self/exe: the real file, whatever the
    /// name or link it was started by).
    std::filesystem::path own_folder(const char *argv0)
    {
      std::error_code ec;
      const auto      self = std::filesystem::read_symlink("/proc/self/exe", ec);
      if (!ec)
        return self.parent_path();
      return std::filesystem::absolute(argv0).parent_path();
    }
  } // namespace

  int forward_to_fe(int argc, char **argv)
  {
    std::string command;
    for (int i = 1; i < argc && command.empty(); ++i)
      if (argv[i][0] != '-')
        command = argv[i];
      else
        return 0; // an option before the command (--help, --version): the front end's
    bool is_fe = false;
    for (const auto &[name, description] : fe_commands())
      is_fe = is_fe || name == command;
    if (!is_fe)
      return 0;
    const auto fe = own_folder(argv[0]) / "rectify-fe";
    std::vector<char *> args(argv, argv + argc);
    args.push_back(nullptr);
    const std::string name = fe.string();
    execv(name.c_str(), args.data()); // argv[0] kept: help texts name `rectify`
    std::fprintf(stderr, "rectify: failed: cannot run %s for '%s': %s\n", name.c_str(),
                 command.c_str(), std::strerror(errno));
    return 1;
  }
} // namespace rectify::app
