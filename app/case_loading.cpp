// Reading a case file for any subcommand: every stage's parameters are read
// (and range-checked) so that a key no stage knows is reported whichever
// subcommand runs.
#include "app/commands.h"
#include "stiffness_solver/parameters.h"
#include "system/parameters.h"

namespace rectify::app
{
  CaseFile load_case(const std::filesystem::path &path)
  {
    CaseFile file = CaseFile::load(path);
    (void)system::SystemParameters::from_case(file);
    (void)stiffness::StiffnessParameters::from_case(file);
    file.check_all_keys_known();
    return file;
  }
} // namespace rectify::app
