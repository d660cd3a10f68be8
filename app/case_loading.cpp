#include "app/case_loading.h"

#include "diagnosis/sensors.h"
#include "mesher/parameters.h"
#include "stiffness_solver/parameters.h"
#include "stokes_solver/parameters.h"
#include "stokes_solver/resistance_sweep.h"
#include "system/parameters.h"

namespace rectify::app
{
  CaseFile load_case(const std::filesystem::path &path, bool read_map_sets)
  {
    CaseFile file = CaseFile::load(path);
    check_every_stage(file, read_map_sets);
    return file;
  }

  void check_every_stage(const CaseFile &file, bool read_map_sets)
  {
    // Without read_map_sets, the system's tables are read but its map sets not
    // opened (`design` may be about to write the very map set the case names).
    (void)system::SystemParameters::from_case(file, read_map_sets);
    (void)stokes::SweepSettings::from_case(file);
    (void)stiffness::StiffnessParameters::from_case(file);
    (void)mesher::MeshParameters::from_case(file);
    (void)stokes::FlowParameters::from_case(file);
    (void)diagnosis::SensorLimits::from_case(file);
    file.check_all_keys_known();
  }
} // namespace rectify::app
