#include "diagnosis/kept_fits.h"

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <iterator>
#include <stdexcept>

#include "common/io.h"
#include "common/version.h"

namespace rectify::diagnosis
{
  namespace
  {
    // A double as C's hexadecimal float ("%a"): read back to the last bit,
    // infinities and NaN included (JSON numbers hold neither).
    std::string exact(double v)
    {
      char buf[40];
      std::snprintf(buf, sizeof buf, "%a", v);
      return buf;
    }

    double exact(const nlohmann::json &j)
    {
      const auto   text = j.get<std::string>();
      char        *end  = nullptr;
      const double v    = std::strtod(text.c_str(), &end);
      if (text.empty() || *end != '\0')
        throw std::runtime_error("'" + text + "' is not a number");
      return v;
    }

    nlohmann::json search_to_json(const std::optional<SearchStop> &s)
    {
      if (!s)
        return nullptr;
      return {exact(s->closed), exact(s->reachable), exact(s->restart_needed), exact(s->name_needed)};
    }

    std::optional<SearchStop> search_from(const nlohmann::json &j)
    {
      if (j.is_null())
        return std::nullopt;
      return SearchStop{exact(j.at(0)), exact(j.at(1)), exact(j.at(2)), exact(j.at(3))};
    }

    nlohmann::json ringing_to_json(const std::optional<RingingLog> &r)
    {
      if (!r)
        return nullptr;
      nlohmann::json tries = nlohmann::json::array();
      for (const auto &t : r->tries)
        tries.push_back({exact(t.f), exact(t.grid), exact(t.lines), exact(t.lines_needed), exact(t.six), t.start});
      return {{"no_peak", r->no_peak}, {"tries", tries}};
    }

    std::optional<RingingLog> ringing_from(const nlohmann::json &j)
    {
      if (j.is_null())
        return std::nullopt;
      RingingLog r;
      r.no_peak = j.at("no_peak").get<bool>();
      for (const auto &t : j.at("tries"))
        r.tries.push_back(
          {exact(t.at(0)), exact(t.at(1)), exact(t.at(2)), exact(t.at(3)), exact(t.at(4)), t.at(5).get<bool>()});
      return r;
    }

    nlohmann::json kept_fit(int round, const CandidateResult &c)
    {
      nlohmann::json values = nlohmann::json::array(), u = nlohmann::json::array(),
                     baseline = nlohmann::json::object();
      for (double v : c.values)
        values.push_back(exact(v));
      for (double v : c.u)
        u.push_back(exact(v));
      for (const auto &[key, v] : c.baseline)
        baseline[key] = exact(v);
      return {{"round", round},
              {"effect", c.effect},
              {"values", values},
              {"force_gain", exact(c.force_gain)},
              {"baseline", baseline},
              {"u", u},
              {"k", c.k},
              {"ssr_train", exact(c.ssr_train)},
              {"n_train", c.n_train},
              {"rms_train", exact(c.rms_train)},
              {"rms_heldout", exact(c.rms_heldout)},
              {"bic", exact(c.bic)},
              {"aic", exact(c.aic)},
              {"evaluations", c.evaluations},
              {"wall_time_s", exact(c.wall_time_s)},
              {"failed", c.failed},
              {"message", c.message},
              {"not_restarted", search_to_json(c.not_restarted)},
              {"ringing", ringing_to_json(c.ringing)},
              {"ringing_runs", c.ringing_runs},
              {"ringing_time_s", exact(c.ringing_time_s)}};
    }

    CandidateResult fit_from(const nlohmann::json &j)
    {
      CandidateResult c;
      c.effect = j.at("effect").get<std::string>();
      for (const auto &v : j.at("values"))
        c.values.push_back(exact(v));
      c.force_gain = exact(j.at("force_gain"));
      for (const auto &[key, v] : j.at("baseline").items())
        c.baseline[key] = exact(v);
      for (const auto &v : j.at("u"))
        c.u.push_back(exact(v));
      c.k              = j.at("k").get<int>();
      c.ssr_train      = exact(j.at("ssr_train"));
      c.n_train        = j.at("n_train").get<std::size_t>();
      c.rms_train      = exact(j.at("rms_train"));
      c.rms_heldout    = exact(j.at("rms_heldout"));
      c.bic            = exact(j.at("bic"));
      c.aic            = exact(j.at("aic"));
      c.evaluations    = j.at("evaluations").get<int>();
      c.wall_time_s    = exact(j.at("wall_time_s"));
      c.failed         = j.at("failed").get<bool>();
      c.message        = j.at("message").get<std::string>();
      c.not_restarted  = search_from(j.at("not_restarted"));
      c.ringing        = ringing_from(j.at("ringing"));
      c.ringing_runs   = j.at("ringing_runs").get<int>();
      c.ringing_time_s = exact(j.at("ringing_time_s"));
      return c;
    }

    constexpr const char *kept_fits_name = "diagnosis-partial"; // DIR/NAME.csv and NAME.json

    std::filesystem::path kept_fits_file(const std::filesystem::path &dir, const char *ext)
    {
      return dir / (kept_fits_name + std::string(ext));
    }


    CandidateResult with_time(CandidateResult c, double t)
    {
      c.wall_time_s = t;
      return c;
    }
  } // namespace

  FitStore::FitStore(const DiagnoseOptions &o, const std::function<void(const std::string &)> &say)
    : dir_(o.checkpoint_dir)
    , fingerprint_(o.checkpoint_fingerprint)
    , say_(say)
  {
    if (Checkpoint::holds_other(dir_, kept_fits_name, fingerprint_))
      discard("another diagnosis's (other settings, inputs or revision)");
    open();
    for (const auto &row : file_->finished_rows())
      {
        // a row this revision cannot read (the fingerprint names the
        // revision, so only a damaged file has one) discards them all
        try
          {
            const auto j = nlohmann::json::parse(row);
            kept_[{j.at("round").get<int>(), j.at("effect").get<std::string>()}] = fit_from(j);
          }
        catch (const std::exception &e)
          {
            kept_.clear();
            discard(std::string("unreadable (") + e.what() + ")");
            open();
            break;
          }
      }
    if (!kept_.empty())
      say_("resuming: " + std::to_string(kept_.size()) + " fit(s) of an interrupted run of this diagnosis kept in " +
           kept_fits_file(dir_, ".csv").string());
  }

  std::optional<CandidateResult> FitStore::find(int round, const std::string &effect) const
  {
    const auto it = kept_.find({round, effect});
    return it == kept_.end() ? std::nullopt : std::optional<CandidateResult>(it->second);
  }

  void FitStore::keep(int round, const CandidateResult &c) { file_->append(kept_fit(round, c).dump()); }

  void FitStore::check_none(int round, const CandidateResult &none)
  {
    const auto old = find(round, "none");
    if (!old)
      {
        keep(round, none);
        return;
      }
    if (kept_fit(round, *old).dump() != kept_fit(round, with_time(none, old->wall_time_s)).dump())
      {
        kept_.clear();
        file_.reset();
        discard("made with other inputs: its none fitted otherwise");
        open();
        keep(round, none);
      }
  }

  void FitStore::discard(const std::string &why)
  {
    say_("discarded the kept fits in " + kept_fits_file(dir_, ".csv").string() + ": " + why);
    remove_checkpoint(dir_);
  }

  void FitStore::open()
  {
    ensure_directory(dir_);
    file_.emplace(dir_, kept_fits_name, fingerprint_, "fit");
  }

  std::size_t kept_fits(const std::filesystem::path &dir)
  {
    std::ifstream in(kept_fits_file(dir, ".csv"));
    const auto    lines = std::count(std::istreambuf_iterator<char>(in), {}, '\n'); // whole rows
    return lines > 1 ? static_cast<std::size_t>(lines - 1) : 0;                      // not the header
  }

  void remove_checkpoint(const std::filesystem::path &dir)
  {
    for (const char *ext : {".csv", ".json"})
      std::filesystem::remove(kept_fits_file(dir, ext));
  }
  void discard_if_nothing_kept(const std::filesystem::path &dir, bool made_dir)
  {
    if (kept_fits(dir) != 0)
      return;
    remove_checkpoint(dir);
    std::error_code ec;
    if (made_dir && std::filesystem::is_empty(dir, ec))
      std::filesystem::remove(dir, ec);
  }

  nlohmann::json checkpoint_fingerprint(const std::string &settings, const std::filesystem::path &case_path,
                                        const std::vector<std::string> &data)
  {
    nlohmann::json data_hashes = nlohmann::json::array();
    for (const auto &d : data)
      data_hashes.push_back(file_hash(d));
    return {{"revision", source_revision()},
            {"version", RECTIFY_VERSION},
            {"settings", settings},
            {"case", file_hash(case_path)},
            {"data", data_hashes}};
  }
} // namespace rectify::diagnosis
