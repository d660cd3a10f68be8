#include "app/case_loading.h"

#include "mesher/parameters.h"
#include "stiffness_solver/parameters.h"
#include "stokes_solver/parameters.h"
#include "system/parameters.h"

namespace rectify::app
{
  CaseFile load_case(const std::filesystem::path &path)
  {
    CaseFile file = CaseFile::load(path);
    (void)system::SystemParameters::from_case(file);
    (void)stiffness::StiffnessParameters::from_case(file);
    (void)mesher::MeshParameters::from_case(file);
    (void)stokes::FlowParameters::from_case(file);
    file.check_all_keys_known();
    return file;
  }
} // namespace rectify::app
