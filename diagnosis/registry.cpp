// The effect library. To add an effect, write effects/<name>.cpp with
// `make_<name>()` (CMake picks the file up), declare it here and list it
// below (docs/adding-an-effect.md).
#include "diagnosis/effect.h"

namespace rectify::diagnosis
{
  std::shared_ptr<const Effect> make_entrained_air();
  std::shared_ptr<const Effect> make_entrained_air_constant_modulus();
  std::shared_ptr<const Effect> make_outlet_compliance();
  std::shared_ptr<const Effect> make_valve_leakage();
  std::shared_ptr<const Effect> make_valve_leakage_turbulent();
  std::shared_ptr<const Effect> make_orifice_flow();
  std::shared_ptr<const Effect> make_line_inertance();
  std::shared_ptr<const Effect> make_coil_dynamics();
  std::shared_ptr<const Effect> make_piston_friction();
  std::shared_ptr<const Effect> make_reed_second_mode();

  const std::vector<std::shared_ptr<const Effect>> &effect_library()
  {
    static const std::vector<std::shared_ptr<const Effect>> library{
      make_entrained_air(),   make_entrained_air_constant_modulus(), make_outlet_compliance(),
      make_valve_leakage(),   make_valve_leakage_turbulent(),        make_orifice_flow(),
      make_line_inertance(),  make_coil_dynamics(),                  make_piston_friction(),
      make_reed_second_mode()};
    return library;
  }
} // namespace rectify::diagnosis
