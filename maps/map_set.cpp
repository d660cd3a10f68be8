#include "maps/map_set.h"

#include <cmath>
#include <fstream>

#include "common/case_file.h"
#include "common/io.h"
#include "common/version.h"

namespace rectify::maps
{
  namespace
  {
    const char *const resistance_file = "resistance.csv";
    const char *const area_file       = "area.csv";
    const char *const loading_file    = "loading.csv";

    /// The field `key` of `j` (an object), or an InputError naming `where` and the key.
    const nlohmann::json &field(const nlohmann::json &j, const std::string &key, const std::string &where)
    {
      if (!j.is_object() || !j.contains(key))
        throw InputError(where + ": missing field \"" + key + "\"");
      return j.at(key);
    }

    double number(const nlohmann::json &j, const std::string &key, const std::string &where)
    {
      const auto &v = field(j, key, where);
      if (!v.is_number() || !std::isfinite(v.get<double>()))
        throw InputError(where + ": field \"" + key + "\" = " + v.dump() + " is not a finite number");
      return v.get<double>();
    }

    std::string text(const nlohmann::json &j, const std::string &key, const std::string &where)
    {
      const auto &v = field(j, key, where);
      if (!v.is_string())
        throw InputError(where + ": field \"" + key + "\" = " + v.dump() + " is not a string");
      return v.get<std::string>();
    }
  } // namespace

  nlohmann::json ReedProperties::to_json() const
  {
    return {{"stiffness_N_per_m", stiffness_N_per_m},
            {"modal_mass_kg", modal_mass_kg},
            {"modal_mass_in_fluid_kg", modal_mass_in_fluid_kg},
            {"effective_mass_eq321_kg", effective_mass_eq321_kg},
            {"frequency_Hz", frequency_Hz},
            {"frequency_in_fluid_Hz", frequency_in_fluid_Hz},
            {"plate_mass_kg", plate_mass_kg},
            {"added_mass_kg", added_mass_kg},
            {"root_stress_per_opening_Pa_per_m", root_stress_per_opening_Pa_per_m},
            {"root_stress_beam_per_opening_Pa_per_m", root_stress_beam_per_opening_Pa_per_m},
            {"root_stress_concentration", root_stress_concentration},
            {"second_mode_root_stress_per_opening_Pa_per_m", second_mode_root_stress_per_opening_Pa_per_m}};
  }

  ReedProperties ReedProperties::from_json(const nlohmann::json &j, const std::string &where)
  {
    ReedProperties r;
    r.stiffness_N_per_m       = number(j, "stiffness_N_per_m", where);
    r.modal_mass_kg           = number(j, "modal_mass_kg", where);
    r.modal_mass_in_fluid_kg  = number(j, "modal_mass_in_fluid_kg", where);
    r.effective_mass_eq321_kg = number(j, "effective_mass_eq321_kg", where);
    r.frequency_Hz            = number(j, "frequency_Hz", where);
    r.frequency_in_fluid_Hz   = number(j, "frequency_in_fluid_Hz", where);
    r.plate_mass_kg           = number(j, "plate_mass_kg", where);
    r.added_mass_kg           = number(j, "added_mass_kg", where);
    if (j.contains("root_stress_per_opening_Pa_per_m")) // absent in map sets written before
      {
        r.root_stress_per_opening_Pa_per_m      = number(j, "root_stress_per_opening_Pa_per_m", where);
        r.root_stress_beam_per_opening_Pa_per_m = number(j, "root_stress_beam_per_opening_Pa_per_m", where);
        r.root_stress_concentration             = number(j, "root_stress_concentration", where);
        r.second_mode_root_stress_per_opening_Pa_per_m =
          number(j, "second_mode_root_stress_per_opening_Pa_per_m", where);
        if (!(r.root_stress_per_opening_Pa_per_m > 0))
          throw InputError(where + ": root_stress_per_opening_Pa_per_m = " +
                           format_number(r.root_stress_per_opening_Pa_per_m) + ": must be positive");
      }
    for (double v : {r.stiffness_N_per_m, r.modal_mass_kg, r.modal_mass_in_fluid_kg, r.effective_mass_eq321_kg})
      if (!(v > 0))
        throw InputError(where + ": the reed's stiffness and masses must be positive, got " + format_number(v));
    return r;
  }

  nlohmann::json physical_tables(const ValveGeometry &g, const FluidParameters &fluid, const ReedMaterial &m)
  {
    return {{"geometry", g.to_json()},
            {"fluid", {{"density_kg_per_m3", fluid.density_kg_per_m3}, {"viscosity_Pa_s", fluid.viscosity_Pa_s}}},
            {"reed_material",
             {{"youngs_modulus_Pa", m.youngs_modulus_Pa},
              {"poisson_ratio", m.poisson_ratio},
              {"density_kg_per_m3", m.density_kg_per_m3}}}};
  }

  nlohmann::json hashed_tables(const nlohmann::json &tables)
  {
    nlohmann::json out = nlohmann::json::object();
    for (const auto &[name, values] : tables.items())
      out[name] = {{"values", values}, {"hash", content_hash(values.dump())}};
    return out;
  }

  MapSet::MapSet(ResistanceMap resistance, AreaMap area, double seated_area_m2, std::optional<ReedProperties> reed,
                 nlohmann::json manifest)
    : resistance_(std::move(resistance))
    , area_(std::move(area))
    , seated_area_m2_(seated_area_m2)
    , reed_(std::move(reed))
    , manifest_(std::move(manifest))
    , name_(resistance_.name())
  {
    if (!(seated_area_m2_ > 0) || !std::isfinite(seated_area_m2_))
      throw InputError("map set '" + name_ + "': seated_area_m2 = " + format_number(seated_area_m2_) +
                       " must be positive");
  }

  MapSet MapSet::read(const std::filesystem::path &dir)
  {
    const std::string folder = dir.string();
    if (!std::filesystem::is_directory(dir))
      throw InputError("map set '" + folder + "': no such folder");
    const auto manifest_path = dir / "manifest.json";
    if (!std::filesystem::exists(manifest_path))
      throw InputError("map set '" + folder + "': no manifest.json (not a map set, or an unfinished one: run "
                       "`rectify design` again to finish it)");
    nlohmann::json manifest;
    try
      {
        std::ifstream in(manifest_path);
        manifest = nlohmann::json::parse(in);
      }
    catch (const nlohmann::json::exception &e)
      {
        throw InputError("map set '" + manifest_path.string() + "': not valid JSON: " + e.what());
      }
    const std::string where = manifest_path.string();
    if (text(manifest, "format", where) != "rectify map set")
      throw InputError(where + ": field \"format\" is not \"rectify map set\"");
    const int version = static_cast<int>(number(manifest, "format_version", where));
    if (version != map_set_format_version)
      throw InputError(where + ": format_version " + std::to_string(version) + " (this rectify reads " +
                       std::to_string(map_set_format_version) + ")");

    // Tables, each checked against the manifest's hash.
    const auto &files = field(manifest, "files", where);
    const auto  table = [&](const char *file) {
      const auto path = dir / file;
      if (!std::filesystem::exists(path))
        throw InputError("map set '" + folder + "': table " + file + " is missing");
      const std::string expected = text(field(files, file, where + " files"), "hash", where + " files." + file);
      const std::string actual   = file_hash(path);
      if (actual != expected)
        throw InputError("map set '" + folder + "': " + file + " does not match its manifest (hash " + actual +
                         ", manifest " + expected + "): the table was changed after the map set was made");
      return path;
    };
    const auto &r_entry = field(manifest, "resistance", where);
    const auto  interp  = text(r_entry, "interpolation", where + " resistance");
    Interpolation interpolation;
    try
      {
        interpolation = parse_interpolation(interp);
      }
    catch (const InputError &e)
      {
        throw InputError(where + ": resistance.interpolation: " + e.what());
      }
    auto resistance = ResistanceMap::read(table(resistance_file), interpolation);
    auto area       = AreaMap::read(table(area_file));
    const auto &a_entry = field(manifest, "area", where);
    const double seated = number(a_entry, "seated_area_m2", where + " area");
    std::optional<ReedProperties> reed;
    if (manifest.contains("reed") && !manifest.at("reed").is_null())
      reed = ReedProperties::from_json(manifest.at("reed"), where + " reed");
    std::optional<LoadingMap> loading;
    if (manifest.contains("loading") && !manifest.at("loading").is_null())
      loading = LoadingMap::read(table(loading_file));
    MapSet set(std::move(resistance), std::move(area), seated, std::move(reed), std::move(manifest));
    set.loading_ = std::move(loading);
    set.name_ = folder;
    return set;
  }

  void MapSet::write(const std::filesystem::path &dir) const
  {
    ensure_directory(dir);
    // The manifest goes last: its presence marks a finished map set.
    std::filesystem::remove(dir / "manifest.json");
    resistance_.write(dir / resistance_file);
    area_.write(dir / area_file);
    if (loading_)
      loading_->write(dir / loading_file);
    else
      std::filesystem::remove(dir / loading_file);
    nlohmann::json m = manifest_;
    m["format"]         = "rectify map set";
    m["format_version"] = map_set_format_version;
    m["resistance"]     = {{"file", resistance_file},
                           {"interpolation", to_string(resistance_.interpolation())},
                           {"closed_R_Pa_s_per_m3", resistance_.closed_resistance()},
                           {"n_nodes", resistance_.openings().size()}};
    m["area"]           = {{"file", area_file},
                           {"seated_area_m2", seated_area_m2_},
                           {"n_nodes", area_.openings().size()},
                           {"below_first_node", "held (thin-gap limit)"},
                           {"seated", "the force of a seated reed acts on seated_area_m2"}};
    m["reed"]           = reed_ ? reed_->to_json() : nlohmann::json(nullptr);
    m["files"]          = {{resistance_file, {{"hash", file_hash(dir / resistance_file)}}},
                           {area_file, {{"hash", file_hash(dir / area_file)}}}};
    m["loading"]        = nlohmann::json(nullptr);
    if (loading_)
      {
        m["loading"] = {{"file", loading_file},
                        {"n_nodes", loading_->rows().size()},
                        {"referred_to", "the tip: the reed's shape normalised to a unit tip deflection"},
                        {"below_first_node", "c and m_a: the first node's power law, rounded off to at most "
                                             "2^q times their value there on the seat; A_m held "
                                             "(maps/loading_map.h)"},
                        {"above_last_node", "held"}};
        m["files"][loading_file] = {{"hash", file_hash(dir / loading_file)}};
      }
    write_json(dir / "manifest.json", m);
  }

  void MapSet::check_matches(const nlohmann::json &case_tables, const std::string &case_name) const
  {
    if (!manifest_.contains("depends_on"))
      return; // no provenance (the thesis's values)
    const auto &deps = manifest_.at("depends_on");
    for (const auto &[table_name, case_values] : case_tables.items())
      {
        if (!deps.contains(table_name))
          throw InputError("map set '" + name_ + "': its manifest does not record the case table [" + table_name +
                           "] it depends on");
        const auto &mine = field(deps.at(table_name), "values", "map set '" + name_ + "' depends_on." + table_name);
        for (const auto &[key, value] : case_values.items())
          {
            if (!mine.contains(key))
              throw InputError("map set '" + name_ + "': its manifest has no [" + table_name + "] " + key);
            const auto &other = mine.at(key);
            bool        same  = other == value;
            if (!same && value.is_number() && other.is_number())
              {
                const double a = value.get<double>(), b = other.get<double>();
                same           = std::abs(a - b) <= 1e-12 * std::max(std::abs(a), std::abs(b));
              }
            if (!same)
              throw InputError("map set '" + name_ + "' was made for [" + table_name + "] " + key + " = " +
                               other.dump() + ", but the case '" + case_name + "' has " + value.dump() +
                               ": make a map set for this case with `rectify design`");
          }
      }
  }

  MapSet map_set_from_resistance(ResistanceMap resistance, double pressure_area_m2)
  {
    nlohmann::json manifest = {
      {"source", "R(x) map " + resistance.name() + " with a constant force area A_r (the thesis's model)"},
      {"rectify_version", RECTIFY_VERSION},
      {"build", build_info()},
      {"resistance_metadata", resistance.metadata()}};
    AreaMap area = AreaMap::constant(pressure_area_m2, "A_r");
    return MapSet(std::move(resistance), std::move(area), pressure_area_m2, std::nullopt, std::move(manifest));
  }
} // namespace rectify::maps
