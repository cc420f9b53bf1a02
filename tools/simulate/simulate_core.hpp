#pragma once
// The logic of trompo-simulate, shared by the CLI (tools/simulate/trompo_simulate.cpp) and the
// Python module (python/trompo_module.cpp): the Config and its flag parser (parse,
// parse_flags), the checks made before anything is written (validate), the scene and
// scheme dispatch (simulate, dispatch_scheme, run_scheme, run, run_exact) and the rows,
// which go to a RowSink: a CSV file for the CLI, NumPy arrays for Python. Both faces
// therefore compute every row by the same code and give bit-identical numbers.
//
// Ensembles (--ensemble FILE, trompo.ensemble): the same dispatch with an EnsembleRun in
// place of the sink; run() then integrates every member with trompo::integrate_ensemble
// (include/trompo/drivers/ensemble.hpp) and keeps each member's final state.
//
// Not part of the library (include/trompo): an application of it.
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <map>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include <algorithm>
#include <iterator>
#include <limits>
#include <type_traits>
#include <utility>
#if __has_include(<unistd.h>)
#include <unistd.h>
#define TROMPO_SIMULATE_HAVE_ISATTY 1
#endif

#if TROMPO_HAVE_EXACT
#include "trompo/exact/free_body.hpp"
#include "trompo/exact/lagrange_top.hpp"
#endif
#include "trompo/drivers/adaptive.hpp"
#include "trompo/drivers/ensemble.hpp"
#include "trompo/trompo.hpp"

namespace trompo_simulate {

using trompo::invalid_input;
using V3 = Eigen::Vector3d;
using M3 = Eigen::Matrix3d;

constexpr const char* kUsage =
    "usage: trompo-simulate [options]\n"
    "  --case ht0|ht1|ht2|fb1|fb2|sat1|sat2   preset from docs/theory.md §7-8 and docs/spacecraft.md\n"
    "                               (other flags override it)\n"
    "  --scheme simo-alpha|simo-collocation|simo-kappa|geradin-bauchau|geradin-bauchau-paper|rk4|exact|splitting\n"
    "  --alpha A                    simo-alpha only (default 0.5)\n"
    "  --order 2|4|6                symmetric composition of the scheme (default 2: the scheme itself;\n"
    "                               4: triple jump, 6: Kahan-Li)\n"
    "  --composition triple-jump|suzuki-5|kahan-li-9|mclachlan-15|kahan-li-17   a named composition\n"
    "                               (suzuki-5: order 4 in 5 sub-steps, far smaller error than the\n"
    "                               triple jump; mclachlan-15, kahan-li-17: order 8)\n"
    "  --composition blanes-casas-murua-13   processed order 6: a 13-step kernel between a pre- and a\n"
    "                               post-processor (12 steps each), every row post-processed\n"
    "  splitting (explicit, spin-exact; docs/splitting.md):\n"
    "  --composition strang|chin-4a|chin-triple-jump|suzuki-5|kahan-li-9|saba2c|saba3c|saba4c|sbab2c|sbab3c\n"
    "                               with --scheme splitting (suzuki-5, kahan-li-9: compositions of Strang;\n"
    "                               sabaNc, sbabNc: Laskar-Robutel with corrector, small torques); default by\n"
    "                               --order: chin-4a / chin-triple-jump where they apply, else suzuki-5 / kahan-li-9\n"
    "  --energy-projection          splitting: project H back after each step (keeps pi; no value)\n"
    // ---- families (docs/families.md) ----
    "  --scheme lie-gen-alpha|constrained-trapezoid|energy-decaying   the other families\n"
    "  --rho-inf R                  lie-gen-alpha only: spectral radius at infinity in [0, 1] (default 0.8)\n"
    "  --chi X                      energy-decaying only: dissipation in [0, 1] (default 0: energy-momentum)\n"
    "  --chi-schedule constant|sensor   energy-decaying only (default constant)\n"
    "  --inertia J11,J22,J33[,J12,J13,J23]   body axes, about the fixed point\n"
    "  --mgl W                      M*g*l (0 = no gravity)\n"
    "  --com E1,E2,E3               body direction to the centre of mass (normalised)\n"
    "  --up G1,G2,G3                spatial up (normalised)\n"
    "  --rotation R1,R2,R3          initial rotation vector, Lambda0 = exp(R^)\n"
    "  --omega W1,W2,W3             initial body angular velocity\n"
    "  --dt H  --t-end T  [--every K]   write every K-th step (default 1); the last step is always written\n"
    "  --csv FILE                   default: standard output\n"
    "  --damping C                  viscous damping torque -C*Omega (C >= 0)\n"
    "  --allow-negative-damping     accept C < 0 (the torque then feeds energy in; no value)\n"
    "  --torque T1,T2,T3            constant body-fixed torque\n"
    "  --space-torque S1,S2,S3      constant space-fixed torque\n"
    "  --rotor H1,H2,H3             internal rotor angular momentum (body axes)\n"
    "  --gravity-gradient N         a satellite: gravity gradient of a circular orbit of rate N rad/s\n"
    "                               (docs/spacecraft.md); the H column is then the Jacobi integral\n"
    "  --orbit-normal O1,O2,O3      with --gravity-gradient: the orbit normal (default 0,0,1)\n"
    "  --radial R1,R2,R3            with --gravity-gradient: the radial direction at t = 0, orthogonal\n"
    "                               to the orbit normal (default 1,0,0)\n"
    "  --ensemble FILE              integrate every initial state of FILE (CSV with header\n"
    "                               rotation1,rotation2,rotation3,omega1,omega2,omega3[,mgl][,J11,J22,J33[,J12,J13,J23]])\n"
    "                               across cores; writes each member's final state (docs/python.md)\n"
    "  --threads N                  with --ensemble: worker threads (default 0: every core)\n"
    // ---- adaptive steps (docs/adaptive.md) ----
    "  --rtol R [--atol A]          adaptive steps to tolerances R, A (default A 1e-6); --dt is the first step\n"
    "  --control tolerance|reversible   step doubling + PI control (default), or Hairer-Soderlind's\n"
    "                               time-reversible step density (conservative scenes, long runs)\n"
    "  --t-eval T1,T2,...|@FILE     rows at exactly these times (dense output), and only these\n"
    "  --event NAME[:terminal[:N]]  nutation-max|nutation-min|axis-crossing|flip (repeatable)\n"
    "  --event-csv FILE             one row per event: event, then the usual columns\n";

// ---- adaptive steps (--rtol, --atol, --control, --t-eval, --event, --event-csv) ----
/// The adaptive flags (docs/adaptive.md); `on` when --rtol is given.
struct AdaptiveFlags {
  bool on = false;
  double rtol = 1e-3, atol = 1e-6;  ///< SciPy's defaults (--rtol is required to switch on)
  std::string control = "tolerance";
  std::vector<double> t_eval;                         ///< --t-eval: rows at exactly these times
  std::vector<std::pair<std::string, int>> events;  ///< --event NAME[:terminal[:N]]: name, terminal count
  std::string event_csv;                             ///< --event-csv FILE
};
// ---- end adaptive ----

struct Config {
  AdaptiveFlags adaptive;  ///< --rtol … (adaptive steps)
  std::string scheme = "simo-kappa";
  std::optional<double> alpha;
  M3 inertia = M3::Zero();
  bool have_inertia = false;
  bool unphysical_ok = false;  // only FB2's preset inertia (a test problem) may break J1+J2 >= J3
  double mgl = 0;
  V3 com = V3::UnitZ();
  V3 up = V3::UnitZ();
  V3 rotation = V3::Zero();
  V3 omega = V3::Zero();
  std::optional<double> dt;
  std::optional<double> t_end;
  long every = 1;
  std::string csv;
  int order = 2;
  std::optional<int> order_flag;                    ///< --order as given
  std::optional<trompo::Composition> composition;  ///< --composition as given
  bool processed = false;  ///< --composition blanes-casas-murua-13 (ProcessedStepper)
  double damping = 0;
  bool allow_negative_damping = false;  ///< --allow-negative-damping: a damping C < 0 on purpose
  V3 body_torque = V3::Zero();
  V3 space_torque = V3::Zero();
  V3 rotor = V3::Zero();
  bool have_effects = false;  // any of --damping, --torque, --space-torque, --rotor
  // ---- satellite (docs/spacecraft.md) ----
  std::optional<double> gravity_gradient;  ///< --gravity-gradient N: the orbit rate; a satellite scene
  V3 orbit_normal = V3::UnitZ();           ///< --orbit-normal
  V3 radial = V3::UnitX();                 ///< --radial
  std::string ensemble;       ///< --ensemble FILE: initial states of the members (ensemble.hpp)
  unsigned threads = 0;       ///< --threads N (ensembles; 0 = every core)
  // ---- splitting (--scheme splitting) ----
  std::optional<std::string> composition_name;  ///< --composition as given (splitting names too)
  bool energy_projection = false;               ///< --energy-projection
  // ---- families (docs/families.md) ----
  std::optional<double> rho_inf;            ///< --rho-inf (lie-gen-alpha)
  std::optional<double> chi;                ///< --chi (energy-decaying)
  std::optional<std::string> chi_schedule;  ///< --chi-schedule (energy-decaying)
};

inline double parse_number(const std::string& flag, const std::string& text) {
  errno = 0;
  char* end = nullptr;
  const double v = std::strtod(text.c_str(), &end);
  if (text.empty() || end != text.c_str() + text.size() || errno == ERANGE)
    throw invalid_input(flag + ": not a number: '" + text + "'");
  if (!std::isfinite(v)) throw invalid_input(flag + ": must be finite, got " + text);
  return v;
}

inline std::vector<double> parse_list(const std::string& flag, const std::string& text) {
  std::vector<double> out;
  std::size_t start = 0;
  while (true) {
    const std::size_t comma = text.find(',', start);
    out.push_back(parse_number(flag, text.substr(start, comma - start)));
    if (comma == std::string::npos) break;
    start = comma + 1;
  }
  return out;
}

inline V3 parse_vector(const std::string& flag, const std::string& text) {
  const auto v = parse_list(flag, text);
  if (v.size() != 3) throw invalid_input(flag + ": expected 3 comma-separated numbers, got '" + text + "'");
  return V3(v[0], v[1], v[2]);
}

/// Presets (docs/theory.md §7-8). dt defaults: the finest h the theory names for the case.
inline void apply_case(const std::string& name, Config& c) {
  auto from = [&](const auto& preset, double dt) {
    c.inertia = preset.scene.body().inertia();
    c.have_inertia = true;
    c.unphysical_ok = !preset.scene.body().is_physical();
    c.omega = preset.initial.omega;
    c.rotation = preset.initial.rotation.log();
    c.t_end = preset.t_end;
    c.dt = dt;
    using SceneT = std::decay_t<decltype(preset.scene)>;
    if constexpr (std::is_same_v<SceneT, trompo::cases::Satellite<double>>) {
      const auto& g = preset.scene.template effect<trompo::GravityGradient<double>>();
      c.mgl = 0;
      c.gravity_gradient = g.orbit_rate();
      c.orbit_normal = g.orbit_normal();
      c.radial = g.radial();
    } else if constexpr (!SceneT::is_free) {
      const auto& g = preset.scene.template effect<trompo::UniformGravity<double>>();
      c.mgl = g.Mgl();
      c.com = g.com_direction();
      c.up = g.up();
    } else {
      c.mgl = 0;
    }
  };
  if (name == "ht0") from(trompo::cases::ht0<double>(), 0.001);
  else if (name == "ht1") from(trompo::cases::ht1<double>(), 0.001);
  else if (name == "ht2") from(trompo::cases::ht2<double>(), 0.0005);
  else if (name == "fb1") from(trompo::cases::fb1<double>(), 0.01);
  else if (name == "fb2") from(trompo::cases::fb2<double>(), 0.1);
  else if (name == "sat1") from(trompo::cases::sat1<double>(), 1.0);
  else if (name == "sat2") from(trompo::cases::sat2<double>(), 10.0);
  else throw invalid_input("--case: unknown case '" + name + "' (ht0, ht1, ht2, fb1, fb2, sat1, sat2)");
}

/// Whether `name` is a --scheme the CLI runs.
inline bool known_scheme(const std::string& name) {
  static const char* const schemes[] = {"simo-alpha",      "simo-collocation",      "simo-kappa",
                                        "geradin-bauchau", "geradin-bauchau-paper", "rk4", "exact",
                                        "splitting",       "lie-gen-alpha",         "constrained-trapezoid",
                                        "energy-decaying"};
  return std::any_of(std::begin(schemes), std::end(schemes), [&](const char* s) { return name == s; });
}

// ---- adaptive steps: the flags ----
/// Reads one adaptive flag into `a`; false if `flag` is not one of them.
inline bool parse_adaptive_flag(const std::string& flag, const std::string& value, AdaptiveFlags& a) {
  if (flag == "--rtol") {
    a.on = true;
    a.rtol = parse_number(flag, value);
  } else if (flag == "--atol") {
    a.atol = parse_number(flag, value);
  } else if (flag == "--control") {
    a.control = value;
  } else if (flag == "--t-eval") {
    if (!value.empty() && value[0] == '@') {  // @FILE: one time a line (blank lines skipped)
      std::ifstream in(value.substr(1));
      if (!in) throw invalid_input("--t-eval: cannot open '" + value.substr(1) + "'");
      std::string line;
      while (std::getline(in, line)) {
        if (line.find_first_not_of(" \t\r") == std::string::npos) continue;
        a.t_eval.push_back(parse_number(flag, line));
      }
      if (a.t_eval.empty()) throw invalid_input("--t-eval: no time in '" + value.substr(1) + "'");
    } else {
      a.t_eval = parse_list(flag, value);
    }
  } else if (flag == "--event") {
    std::stringstream list(value);
    std::string item;
    while (std::getline(list, item, ';')) {
      // NAME, NAME:terminal (the first occurrence ends the run) or NAME:terminal:N (the N-th)
      const auto colon = item.find(':');
      const std::string name = item.substr(0, colon);
      int terminal = 0;
      if (colon != std::string::npos) {
        const std::string rest = item.substr(colon + 1);
        if (rest == "terminal") terminal = 1;
        else if (rest.rfind("terminal:", 0) == 0) {
          const double n = parse_number(flag, rest.substr(9));
          if (!(n >= 1 && n <= 1e9) || n != std::floor(n))
            throw invalid_input("--event " + item + ": the count must be a positive integer");
          terminal = static_cast<int>(n);
        } else {
          throw invalid_input("--event " + item + ": expected NAME, NAME:terminal or NAME:terminal:N");
        }
      }
      a.events.emplace_back(name, terminal);
    }
  } else if (flag == "--event-csv") {
    a.event_csv = value;
  } else {
    return false;
  }
  return true;
}
inline void check_adaptive(const Config& c, const std::map<std::string, std::string>& flags);
// ---- end adaptive ----

/// The flags (name with its "--" → value) as a Config, with the CLI's checks and messages.
/// trompo-simulate's parse() and the Python module (python/trompo_module.cpp) both come here.
inline Config parse_flags(const std::map<std::string, std::string>& flags) {
  Config c;
  // The preset first; every other flag overrides it.
  if (auto it = flags.find("--case"); it != flags.end()) apply_case(it->second, c);
  for (const auto& [flag, value] : flags) {
    if (flag == "--case") continue;
    else if (flag == "--scheme") c.scheme = value;
    else if (flag == "--alpha") c.alpha = parse_number(flag, value);
    else if (flag == "--inertia") {
      const auto v = parse_list(flag, value);
      if (v.size() != 3 && v.size() != 6)
        throw invalid_input("--inertia: expected J11,J22,J33 or J11,J22,J33,J12,J13,J23, got '" + value + "'");
      c.inertia = M3::Zero();
      c.inertia.diagonal() << v[0], v[1], v[2];
      if (v.size() == 6) {
        c.inertia(0, 1) = c.inertia(1, 0) = v[3];
        c.inertia(0, 2) = c.inertia(2, 0) = v[4];
        c.inertia(1, 2) = c.inertia(2, 1) = v[5];
      }
      c.have_inertia = true;
      c.unphysical_ok = false;
    } else if (flag == "--mgl") c.mgl = parse_number(flag, value);
    else if (flag == "--com") c.com = parse_vector(flag, value);
    else if (flag == "--up") c.up = parse_vector(flag, value);
    else if (flag == "--rotation") c.rotation = parse_vector(flag, value);
    else if (flag == "--omega") c.omega = parse_vector(flag, value);
    else if (flag == "--dt") c.dt = parse_number(flag, value);
    else if (flag == "--t-end") c.t_end = parse_number(flag, value);
    else if (flag == "--every") {
      const double k = parse_number(flag, value);
      if (!(k >= 1) || k != std::floor(k) || k > 1e15) throw invalid_input("--every: must be a positive integer, got " + value);
      c.every = static_cast<long>(k);
    } else if (flag == "--csv") c.csv = value;
    else if (flag == "--order") {
      const double k = parse_number(flag, value);
      if (k != 2 && k != 4 && k != 6) throw invalid_input("--order: must be 2, 4 or 6, got " + value);
      c.order = static_cast<int>(k);
      c.order_flag = c.order;
    } else if (flag == "--energy-projection") {
      if (!value.empty()) throw invalid_input("--energy-projection: a switch, it takes no value (got '" + value + "')");
      c.energy_projection = true;
    } else if (flag == "--composition") {
      c.composition_name = value;
      bool known = false;  // the splitting's own methods (strang, chin-4a, …, saba4c, sbab3c)
      for (const auto m : trompo::all_splitting_methods)
        if (value == trompo::to_string(m) && value != "suzuki-5" && value != "kahan-li-9") known = true;
      for (const auto m : {trompo::Composition::triple_jump, trompo::Composition::suzuki5, trompo::Composition::kahan_li9,
                           trompo::Composition::mclachlan15, trompo::Composition::kahan_li17})
        if (value == trompo::to_string(m)) {
          c.composition = m;
          known = true;
        }
      if (value == "blanes-casas-murua-13") c.processed = known = true;
      if (!known)
        throw invalid_input("--composition: must be triple-jump, suzuki-5, kahan-li-9, mclachlan-15, kahan-li-17 or blanes-casas-murua-13 (with --scheme splitting: strang, "
                            "chin-4a, chin-triple-jump, suzuki-5, kahan-li-9, saba2c, saba3c, saba4c, sbab2c or sbab3c), got " + value);
    } else if (flag == "--allow-negative-damping") {
      if (!value.empty()) throw invalid_input("--allow-negative-damping: a switch, it takes no value (got '" + value + "')");
      c.allow_negative_damping = true;
    } else if (flag == "--damping") {
      c.damping = parse_number(flag, value);
      c.have_effects = true;
    } else if (flag == "--torque") {
      c.body_torque = parse_vector(flag, value);
      c.have_effects = true;
    } else if (flag == "--space-torque") {
      c.space_torque = parse_vector(flag, value);
      c.have_effects = true;
    } else if (flag == "--rotor") {
      c.rotor = parse_vector(flag, value);
      c.have_effects = true;
    }
    // ---- satellite ----
    else if (flag == "--gravity-gradient") c.gravity_gradient = parse_number(flag, value);
    else if (flag == "--orbit-normal") c.orbit_normal = parse_vector(flag, value);
    else if (flag == "--radial") c.radial = parse_vector(flag, value);
    // ---- families (docs/families.md) ----
    else if (flag == "--rho-inf") c.rho_inf = parse_number(flag, value);
    else if (flag == "--chi") c.chi = parse_number(flag, value);
    else if (flag == "--chi-schedule") c.chi_schedule = value;
    else if (flag == "--ensemble") c.ensemble = value;
    else if (flag == "--threads") {
      const double k = parse_number(flag, value);
      if (!(k >= 0) || k != std::floor(k) || k > 4096) throw invalid_input("--threads: must be an integer in [0, 4096], got " + value);
      c.threads = static_cast<unsigned>(k);
    }
    else if (parse_adaptive_flag(flag, value, c.adaptive)) continue;  // adaptive steps
    else throw invalid_input("unknown option '" + flag + "' (see --help)");
  }
  // The scheme name before any check of a per-scheme flag (--alpha, --rho-inf, …): those
  // checks name the scheme they need, which misleads when the name itself is a typo.
  if (!known_scheme(c.scheme)) throw invalid_input("--scheme: unknown scheme '" + c.scheme + "'");
  if (!c.have_inertia) throw invalid_input("--inertia: required (or give --case)");
  if (!c.dt) throw invalid_input("--dt: required (or give --case)");
  if (!c.t_end) throw invalid_input("--t-end: required (or give --case)");
  if (*c.dt == 0) throw invalid_input("--dt: must be non-zero, got 0");
  if (*c.t_end != 0 && (*c.t_end > 0) != (*c.dt > 0))
    throw invalid_input("--t-end: " + std::to_string(*c.t_end) + " lies behind the start for --dt " +
                        std::to_string(*c.dt));
  // A negative coefficient makes -C*Omega drive the spin: energy grows without bound. Run
  // only when asked for by name (a sign typo otherwise passes as a plausible run).
  if (c.damping < 0 && !c.allow_negative_damping)
    throw invalid_input("--damping: negative coefficient " + flags.at("--damping") +
                        " feeds energy in; give --allow-negative-damping to run it anyway");
  if (c.alpha && c.scheme != "simo-alpha") throw invalid_input("--alpha: only with --scheme simo-alpha");
  // ---- satellite: its own scene (gravity gradient only) ----
  if (!c.gravity_gradient && (flags.count("--orbit-normal") || flags.count("--radial")))
    throw invalid_input(std::string(flags.count("--orbit-normal") ? "--orbit-normal" : "--radial") +
                        ": only with --gravity-gradient (or --case sat1|sat2)");
  if (c.gravity_gradient) {
    if (c.mgl != 0 || c.have_effects)
      throw invalid_input("--gravity-gradient: a satellite scene has the gravity gradient only (no --mgl, --damping, "
                          "--torque, --space-torque or --rotor)");
    if (c.scheme == "exact") throw invalid_input("--scheme exact: no closed form for a satellite (--gravity-gradient)");
    if (c.scheme == "energy-decaying")
      throw invalid_input("--scheme energy-decaying: its torque average [T12] needs a potential linear in the attitude "
                          "(uniform gravity), not --gravity-gradient");
    if (!c.ensemble.empty()) throw invalid_input("--ensemble: not with --gravity-gradient (one satellite at a time)");
  }
  if (c.ensemble.empty() && flags.count("--threads")) throw invalid_input("--threads: only with --ensemble");
  // ---- families (docs/families.md): parameters and what the schemes accept ----
  if (c.rho_inf && c.scheme != "lie-gen-alpha") throw invalid_input("--rho-inf: only with --scheme lie-gen-alpha");
  if (c.rho_inf && !(*c.rho_inf >= 0 && *c.rho_inf <= 1))
    throw invalid_input("--rho-inf: must be in [0, 1], got " + std::to_string(*c.rho_inf));
  if ((c.chi || c.chi_schedule) && c.scheme != "energy-decaying")
    throw invalid_input(std::string(c.chi ? "--chi" : "--chi-schedule") + ": only with --scheme energy-decaying");
  if (c.chi && !(*c.chi >= 0 && *c.chi <= 1)) throw invalid_input("--chi: must be in [0, 1], got " + std::to_string(*c.chi));
  if (c.chi_schedule && *c.chi_schedule != "constant" && *c.chi_schedule != "sensor")
    throw invalid_input("--chi-schedule: must be constant or sensor, got '" + *c.chi_schedule + "'");
  if ((c.scheme == "constrained-trapezoid" || c.scheme == "energy-decaying") && c.have_effects)
    throw invalid_input("--scheme " + c.scheme +
                        ": the free body or the heavy top only (no --damping, --torque, --space-torque or --rotor)");
  // ---- splitting: its compositions are its own methods ----
  if (c.scheme == "splitting") {
    if (c.composition_name) {
      for (const char* implicit_only : {"triple-jump", "mclachlan-15", "kahan-li-17", "blanes-casas-murua-13"})
        if (*c.composition_name == implicit_only)
          throw invalid_input("--composition " + *c.composition_name +
                              ": not a splitting method (strang, chin-4a, chin-triple-jump, suzuki-5, kahan-li-9, saba2c, "
                              "saba3c, saba4c, sbab2c, sbab3c)");
      int k = 6;
      for (const auto m : trompo::all_splitting_methods)
        if (*c.composition_name == trompo::to_string(m)) k = trompo::order_of(m);
      if (c.order_flag && *c.order_flag != k)
        throw invalid_input("--order: " + std::to_string(*c.order_flag) + " contradicts --composition " +
                            *c.composition_name + " (order " + std::to_string(k) + ")");
      c.order = k;
    }
    if (!c.ensemble.empty())
      for (const char* f : {"--rotation", "--omega", "--every"})
        if (flags.count(f)) throw invalid_input(std::string("--ensemble: the initial states come from the file; drop ") + f);
    return c;
  }
  if (c.energy_projection) throw invalid_input("--energy-projection: only with --scheme splitting");
  if (c.composition_name && !c.composition && !c.processed)
    throw invalid_input("--composition " + *c.composition_name + ": only with --scheme splitting");
  // ---- end splitting ----
  if (c.composition) {
    c.order = trompo::CompositionCoefficients<double>::of(*c.composition).order;
    if (c.order_flag && *c.order_flag != c.order)
      throw invalid_input("--order: " + std::to_string(*c.order_flag) + " contradicts --composition " +
                          trompo::to_string(*c.composition) + " (order " + std::to_string(c.order) + ")");
  }
  if (c.processed) {
    if (c.order_flag && *c.order_flag != 6)
      throw invalid_input("--order: " + std::to_string(*c.order_flag) +
                          " contradicts --composition blanes-casas-murua-13 (order 6)");
    c.order = 6;
  }
  // The flag that asked for a composition, as the messages below name it.
  const std::string composed_by = c.composition ? "--composition " + std::string(trompo::to_string(*c.composition))
                                  : c.processed ? std::string("--composition blanes-casas-murua-13")
                                                : std::string("--order");
  // ---- families: not composed by the CLI ----
  const bool family = c.scheme == "lie-gen-alpha" || c.scheme == "constrained-trapezoid" || c.scheme == "energy-decaying";
  if (family && c.order != 2)
    throw invalid_input(composed_by + ": order " + std::to_string(c.order) + " needs a symmetric scheme; " + c.scheme +
                        " is not composed by the CLI");
  if (c.order != 2 && (c.scheme == "rk4" || c.scheme == "exact"))
    throw invalid_input(composed_by + ": order " + std::to_string(c.order) + " needs a symmetric implicit scheme, not " +
                        c.scheme);
  if (c.order != 2 && c.scheme == "simo-alpha" && c.alpha && *c.alpha != 0.5)
    throw invalid_input(composed_by + ": simo-alpha is symmetric only for alpha = 0.5");
  if (c.alpha && !(*c.alpha >= 0 && *c.alpha <= 1)) throw invalid_input("--alpha: must be in [0, 1], got " + std::to_string(*c.alpha));
  if (!c.ensemble.empty())
    for (const char* f : {"--rotation", "--omega", "--every"})
      if (flags.count(f)) throw invalid_input(std::string("--ensemble: the initial states come from the file; drop ") + f);
  check_adaptive(c, flags);  // adaptive steps
  return c;
}

/// The checks of the adaptive flags (exit 2 with the reason), after parse_flags' own.
inline void check_adaptive(const Config& c, const std::map<std::string, std::string>& flags) {
  const AdaptiveFlags& a = c.adaptive;
  if (!a.on) {
    for (const char* f : {"--atol", "--control", "--t-eval", "--event", "--event-csv"})
      if (flags.count(f)) throw invalid_input(std::string(f) + ": only with adaptive steps (give --rtol)");
    return;
  }
  if (!(std::isfinite(a.rtol) && a.rtol > 0)) throw invalid_input("--rtol: must be finite and > 0, got " + flags.at("--rtol"));
  if (!(std::isfinite(a.atol) && a.atol >= 0)) throw invalid_input("--atol: must be finite and >= 0, got " + flags.at("--atol"));
  if (a.control != "tolerance" && a.control != "reversible")
    throw invalid_input("--control: must be tolerance or reversible, got '" + a.control + "'");
  if (!c.ensemble.empty()) throw invalid_input("--rtol: adaptive steps are not available with --ensemble");
  if (c.scheme == "exact") throw invalid_input("--rtol: --scheme exact has no steps to adapt (use --t-eval with a scheme)");
  if (c.processed)
    throw invalid_input("--rtol: the processed composition's processor is tied to h (each change of h costs 24 base "
                        "steps): use --order 6 (Kahan-Li) for adaptive steps, or drop --rtol");
  if (!a.t_eval.empty() && flags.count("--every")) throw invalid_input("--every: not with --t-eval (rows at those times only)");
  if (!a.event_csv.empty() && a.events.empty()) throw invalid_input("--event-csv: needs at least one --event");
  const double t0 = 0, t1 = *c.t_end;
  const bool forward = t1 >= t0;
  for (std::size_t i = 0; i < a.t_eval.size(); ++i) {
    const double t = a.t_eval[i];
    if (!std::isfinite(t) || (forward ? (t < t0 || t > t1) : (t > t0 || t < t1)))
      throw invalid_input("--t-eval: time " + std::to_string(t) + " lies outside [0, --t-end]");
    if (i > 0 && (forward ? !(t > a.t_eval[i - 1]) : !(t < a.t_eval[i - 1])))
      throw invalid_input(std::string("--t-eval: times must be strictly ") + (forward ? "increasing" : "decreasing"));
  }
  for (const auto& [name, terminal] : a.events) {
    if (name != "nutation-max" && name != "nutation-min" && name != "axis-crossing" && name != "flip")
      throw invalid_input("--event: unknown event '" + name + "' (nutation-max, nutation-min, axis-crossing, flip)");
    if ((name == "nutation-max" || name == "nutation-min") && c.mgl == 0)
      throw invalid_input("--event " + name + ": needs gravity (--mgl non-zero)");
    (void)terminal;
  }
}

/// The command line as flags, then parse_flags.
inline Config parse(int argc, char** argv) {
  std::map<std::string, std::string> flags;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--help" || a == "-h") {
      std::fputs(kUsage, stdout);
      std::exit(0);
    }
    if (a.rfind("--", 0) != 0) throw invalid_input("unexpected argument '" + a + "'");
    if (a == "--energy-projection" || a == "--allow-negative-damping") {  // the switches: no value
      if (flags.count(a)) throw invalid_input(a + ": given twice");
      flags[a] = "";
      continue;
    }
    if (i + 1 >= argc) throw invalid_input(a + ": missing value");
    if (a == "--event" && flags.count(a)) {  // adaptive: repeatable, kept as a ';' list
      flags[a] += std::string(";") + argv[++i];
      continue;
    }
    if (flags.count(a)) throw invalid_input(a + ": given twice");
    flags[a] = argv[++i];
  }
  return parse_flags(flags);
}

/// Counts the Newton iterations of the steps since the last written row (a recovered
/// interval counts all its sub-steps); forwards to the wrapped stepper.
/// For a scheme with memory (splitting, the families) it has the stepper's Memory and
/// start(), so that integrate() steps a Trajectory through it.
template <class StepperT>
struct CountingStepper {
  using Scalar = double;
  using Memory = typename StepperT::Memory;
  const StepperT& stepper;
  mutable long iterations = 0;
  /// A trajectory with fresh memory (integrate() calls it for a scheme with memory).
  auto start(const trompo::State<double>& s) const { return stepper.start(s); }
  /// A State, or a Trajectory for a scheme with memory.
  template <class StateT>
  trompo::StepReport<double> step(StateT& s, double h) const {
    const auto rep = stepper.step(s, h);
    iterations += rep.iterations;
    return rep;
  }
};

const char* const kHeader = "t,R00,R01,R02,R10,R11,R12,R20,R21,R22,W1,W2,W3,H,mu,pi1,pi2,pi3,iterations\n";

/// Where the rows go: a CSV file for the CLI (CsvSink), NumPy arrays for Python
/// (python/trompo_module.cpp). The values are computed once, in write_row, for both.
/// One virtual call per written row, none per step.
class RowSink {
 public:
  virtual ~RowSink() = default;
  /// Before the first row.
  virtual void header() = 0;
  /// One row: t, Λ, Ω, H, μ, π and the Newton iterations since the last row.
  virtual void row(double t, const M3& R, const V3& W, double H, double mu, const V3& pi, long iterations) = 0;
  /// Rows so far are final (before a failure message).
  virtual void flush() {}
  /// A line for the user (the CLI's stderr), without the program name and newline.
  virtual void message(const std::string& text) = 0;
  /// Whether a long run states its estimated time first (notice): the CLI; not Python (the
  /// caller chose the run, and the probe would cost it time).
  virtual bool announces_long_runs() const { return false; }
  /// A line before a long run starts (its estimated time): the CLI's stderr.
  virtual void notice(const std::string&) {}
  /// Whether progress lines are wanted during the run (the CLI: stderr is a terminal).
  virtual bool shows_progress() const { return false; }
  /// The progress line, rewritten in place; done: the run is over, end the line.
  virtual void progress(const std::string&, bool /*done*/) {}
};

/// The CLI's sink: kHeader and `%.17g` rows to a FILE, messages to stderr.
class CsvSink final : public RowSink {
 public:
  explicit CsvSink(std::FILE* out) : out_(out) {}
  void header() override { std::fputs(kHeader, out_); }
  void row(double t, const M3& R, const V3& W, double H, double mu, const V3& pi, long iterations) override {
    std::fprintf(out_, "%.17g", t);
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) std::fprintf(out_, ",%.17g", R(i, j));
    std::fprintf(out_, ",%.17g,%.17g,%.17g,%.17g,%.17g,%.17g,%.17g,%.17g,%ld\n", W.x(), W.y(), W.z(), H, mu, pi.x(),
                 pi.y(), pi.z(), iterations);
  }
  void flush() override { std::fflush(out_); }
  void message(const std::string& text) override { std::fprintf(stderr, "trompo-simulate: %s\n", text.c_str()); }
  bool announces_long_runs() const override { return true; }
  void notice(const std::string& text) override { message(text); }
  bool shows_progress() const override {
#ifdef TROMPO_SIMULATE_HAVE_ISATTY
    return isatty(fileno(stderr)) != 0;
#else
    return false;
#endif
  }
  void progress(const std::string& text, bool done) override {
    // \r and erase-to-end-of-line: the line is rewritten in place on the terminal.
    std::fprintf(stderr, "\rtrompo-simulate: %s\033[K%s", text.c_str(), done ? "\n" : "");
    std::fflush(stderr);
  }

 private:
  std::FILE* out_;
};

/// printf into a std::string (the CLI's stderr lines, kept word for word).
template <class... Args>
std::string format(const char* fmt, Args... args) {
  char buf[512];
  std::snprintf(buf, sizeof buf, fmt, args...);
  return buf;
}

/// One row of state s.
template <class Scene>
void write_row(RowSink& out, const Scene& scene, const V3& up, const trompo::State<double>& st, long iterations) {
  const M3 R = st.rotation.matrix();
  const V3 pi = scene.spatial_momentum(st);
  out.row(st.time, R, st.omega, scene.energy(st), up.dot(pi), pi, iterations);
}

/// The number of steps of the grid t0 + k·h to t_end (the last one shortened): as integrate().
inline long step_count(const Config& c) {
  const double ratio = *c.t_end / *c.dt;
  const double eps = std::numeric_limits<double>::epsilon();
  return std::max(1L, static_cast<long>(std::ceil(ratio - 8 * eps * std::max(ratio, 1.0))));
}

// ---- adaptive steps: the run (--rtol) ----
/// Runs `stepper` through trompo::integrate_adaptive (drivers/adaptive.hpp): rows at every
/// --every-th accepted step (and the last), or at exactly the --t-eval times from the dense
/// output; --event rows to --event-csv ("event," then the usual columns); one summary line.
template <class StepperT>
int run_adaptive(const StepperT& stepper, const Config& c, trompo::State<double> s, RowSink& out) {
  using namespace trompo;
  if constexpr (detail::is_processed<StepperT>()) {
    throw invalid_input("--rtol: the processed composition's processor is tied to h: use --order 6");
  } else {
    const AdaptiveFlags& a = c.adaptive;
    const auto& scene = stepper.scene();
    const V3 up = c.up.normalized();
    AdaptiveOptions<double> opt;
    opt.rtol = a.rtol;
    opt.atol = a.atol;
    opt.control = a.control == "reversible" ? StepControl::reversible : StepControl::tolerance;
    opt.first_step = std::abs(*c.dt);
    std::vector<Event<double>> ev;
    for (const auto& [name, terminal] : a.events) ev.push_back(events::by_name(scene, name, terminal));
    std::FILE* event_file = nullptr;
    if (!a.event_csv.empty()) {
      event_file = std::fopen(a.event_csv.c_str(), "w");
      if (!event_file) throw invalid_input("--event-csv: cannot open '" + a.event_csv + "': " + std::strerror(errno));
      std::fprintf(event_file, "event,%s", kHeader);
    }
    out.header();
    const bool at_times = !a.t_eval.empty();
    std::size_t next = 0;
    long k = 0, written_iterations = 0;
    double last_row = std::numeric_limits<double>::quiet_NaN();
    auto row = [&](const State<double>& st, long iterations) {
      write_row(out, scene, up, st, iterations - written_iterations);
      written_iterations = iterations;
      last_row = st.time;
    };
    if (!at_times || a.t_eval[0] == s.time) {
      row(s, 0);
      next = at_times ? 1 : 0;
    }
    auto observer = [&](const DenseNode<double>& na, const DenseNode<double>& nb, const AdaptiveSummary<double>& sum) {
      const long its = static_cast<long>(sum.iterations);
      if (!at_times) {
        if (++k % c.every == 0) row(nb.state, its);
        return;
      }
      const double tb = nb.state.time;
      const bool forward = tb >= na.state.time;
      if (next < a.t_eval.size() && (forward ? a.t_eval[next] <= tb : a.t_eval[next] >= tb)) {
        const LieHermite<double> seg(na, nb, opt.quintic);
        while (next < a.t_eval.size() && (forward ? a.t_eval[next] <= tb : a.t_eval[next] >= tb)) {
          row(a.t_eval[next] == tb ? nb.state : seg.state(a.t_eval[next]), its);
          ++next;
        }
      }
    };
    auto sink = [&](int index, const State<double>& st, bool) {
      if (!event_file) return;
      std::fprintf(event_file, "%s,", ev[static_cast<std::size_t>(index)].name.c_str());
      CsvSink(event_file).row(st.time, st.rotation.matrix(), st.omega, scene.energy(st), up.dot(scene.spatial_momentum(st)),
                              scene.spatial_momentum(st), 0);
    };
    const AdaptiveSummary<double> sum = integrate_adaptive(stepper, s, *c.t_end, opt, observer, &ev, sink);
    if (!at_times && !(s.time == last_row)) row(s, static_cast<long>(sum.iterations));  // the end, always
    if (event_file) std::fclose(event_file);
    out.message(format("adaptive (%s, rtol %g, atol %g): %lld accepted, %lld rejected, %lld failed attempts, %lld Newton "
                       "iterations; %s",
                       a.control.c_str(), a.rtol, a.atol, static_cast<long long>(sum.accepted),
                       static_cast<long long>(sum.rejected), static_cast<long long>(sum.failures),
                       static_cast<long long>(sum.iterations),
                       sum.status == AdaptiveStatus::event ? "stopped by a terminal event"
                       : sum.ok()                          ? "reached t_end"
                                                           : sum.message()));
    if (!sum.ok()) {
      out.flush();
      out.message(format("adaptive run failed at t = %.17g: %s", s.time, sum.message()));
      return 3;
    }
    return 0;
  }
}
// ---- end adaptive ----

// ---- long runs: the estimate before, the progress during ----------------------------------

/// A run of more steps than this states its estimated time before it starts.
constexpr double kAnnounceSteps = 1e8;
/// Progress lines (stderr a terminal only) begin after this many seconds, then once a second.
constexpr double kProgressAfter = 3.0;

/// A duration for a person: seconds up to two minutes, then minutes, hours, days, years.
inline std::string duration_text(double seconds) {
  if (!(seconds < 1e300)) return "forever";
  if (seconds < 120) return format("%.3g s", seconds);
  if (seconds < 2 * 3600) return format("%.3g min", seconds / 60);
  if (seconds < 2 * 86400) return format("%.3g h", seconds / 3600);
  if (seconds < 2 * 365.25 * 86400) return format("%.3g days", seconds / 86400);
  return format("%.3g years", seconds / (365.25 * 86400));
}

/// Seconds per grid step of `stepper` from state s, timed on a short probe: the same
/// integrate() with the same rows (every c.every-th step, formatted by a CsvSink into
/// /dev/null, so that a run with --every 1 counts its output too) on a copy of s, 64, 256,
/// … steps until one probe takes 50 ms or 4^10 steps. The run itself and its output are not
/// touched. Returns {seconds per step, steps timed}; {NaN, m} when the probe failed a step.
template <class StepperT>
std::pair<double, long> time_per_step(const StepperT& stepper, const Config& c, const trompo::State<double>& s) {
  using clock = std::chrono::steady_clock;
  std::FILE* null = std::fopen("/dev/null", "w");  // no rows timed where there is none
  CsvSink sink(null);
  const V3 up = c.up.normalized();
  const double h = *c.dt;
  std::pair<double, long> result{std::numeric_limits<double>::quiet_NaN(), 0};
  for (long m = 64;; m *= 4) {
    trompo::State<double> probe = s;
    long k = -1;
    const auto start = clock::now();
    const auto sum = trompo::integrate(stepper, probe, s.time + static_cast<double>(m) * h, h,
                                       [&](const trompo::State<double>& st) {
                                         if (null && ++k % c.every == 0) write_row(sink, stepper.scene(), up, st, 0);
                                       });
    const double elapsed = std::chrono::duration<double>(clock::now() - start).count();
    result = {sum.ok() ? elapsed / static_cast<double>(m) : std::numeric_limits<double>::quiet_NaN(), m};
    if (!sum.ok() || elapsed >= 0.05 || m >= (1L << 20)) break;
  }
  if (null) std::fclose(null);
  return result;
}

/// The line a run of more than kAnnounceSteps steps prints before it starts.
template <class StepperT>
std::string estimate_text(const StepperT& stepper, const Config& c, const trompo::State<double>& s, double steps) {
  const auto [per_step, timed] = time_per_step(stepper, c, s);
  if (!(per_step >= 0))
    return format("%.3g steps of h = %.17g: no time estimate (a step of the %ld-step probe failed)", steps, *c.dt,
                  timed);
  return format("%.3g steps of h = %.17g: estimated %s (%.3g s a step, timed on a probe of %ld steps)", steps, *c.dt,
                duration_text(per_step * steps).c_str(), per_step, timed);
}

/// Runs `stepper` through trompo::integrate (failed steps are retried as sub-steps) and
/// writes the CSV rows. More than kAnnounceSteps steps: the estimated time on stderr first;
/// stderr a terminal: a progress line once a second after the first kProgressAfter seconds.
template <class StepperT>
int run(const StepperT& stepper, const Config& c, trompo::State<double> s, RowSink& out) {
  if (c.adaptive.on) return run_adaptive(stepper, c, s, out);  // adaptive steps (--rtol)
  const auto& scene = stepper.scene();
  const V3 up = c.up.normalized();  // μ = γ·π about the given up axis, with or without gravity
  const double steps = std::abs((*c.t_end - s.time) / *c.dt);
  if (steps > kAnnounceSteps && out.announces_long_runs()) out.notice(estimate_text(stepper, c, s, steps));
  out.header();
  const long n = step_count(c);
  const CountingStepper<StepperT> counting{stepper};
  using clock = std::chrono::steady_clock;
  const bool progress = out.shows_progress();
  const auto start = clock::now();
  double next_progress = kProgressAfter;
  bool progress_shown = false;
  long k = -1;  // the observer's first call is at t0
  auto observer = [&](const trompo::State<double>& st) {
    ++k;
    if (k == 0 || k % c.every == 0 || k == n) {
      write_row(out, scene, up, st, counting.iterations);
      counting.iterations = 0;
    }
    if (progress && (k & 0xFFF) == 0) {  // the clock every 4096 steps
      const double elapsed = std::chrono::duration<double>(clock::now() - start).count();
      if (elapsed >= next_progress) {
        const double done = static_cast<double>(k) / static_cast<double>(n);
        out.progress(format("t = %.6g of %.6g (%.1f%%), %s elapsed, about %s left", st.time, *c.t_end, 100 * done,
                            duration_text(elapsed).c_str(), duration_text(elapsed * (1 - done) / done).c_str()),
                     false);
        progress_shown = true;
        next_progress = elapsed + 1;
      }
    }
  };
  const auto sum = trompo::integrate(counting, s, *c.t_end, *c.dt, observer);
  if (progress_shown)
    out.progress(format("t = %.6g of %.6g, %s after %s", s.time, *c.t_end, sum.ok() ? "done" : "stopped",
                        duration_text(std::chrono::duration<double>(clock::now() - start).count()).c_str()),
                 true);
  if (sum.recovered > 0)
    out.message(format("%lld interval(s) recovered by sub-stepping (%lld failed attempts, %lld sub-steps, depth <= %d)",
                       static_cast<long long>(sum.recovered), static_cast<long long>(sum.failures),
                       static_cast<long long>(sum.substeps), sum.max_depth));
  if (!sum.ok()) {
    out.flush();
    out.message(format("step failed at t = %.17g (h = %.17g), not recovered by sub-stepping: %s", s.time, *c.dt,
                       sum.reason()));
    return 3;
  }
  return 0;
}

/// The closed form (docs/theory.md §8) on the same grid: the Lagrange top (J diagonal with
/// J11 = J22, centre of mass on body axis 3) or the torque-free body (J diagonal).
inline int run_exact(const Config& c, const trompo::RigidBody<double>& body, const trompo::State<double>& s0, RowSink& out) {
  using namespace trompo;
#if !TROMPO_HAVE_EXACT
  (void)body, (void)s0, (void)out;
  throw invalid_input("--scheme exact: this build has no closed forms (Boost.Math headers were not found)");
#else
  const M3& J = body.inertia();
  const double scale = J.cwiseAbs().maxCoeff();
  if (c.have_effects) throw invalid_input("--scheme exact: no closed form with damping, torques or a rotor");
  if (!body.is_diagonal()) throw invalid_input("--scheme exact: no closed form for a non-diagonal inertia (give principal axes)");
  const M3 L0 = s0.rotation.matrix();
  auto emit = [&](const auto& exact, const auto& scene) {
    out.header();
    const long n = step_count(c);
    for (long k = 0; k <= n; ++k) {
      State<double> s;
      s.time = (k == n) ? *c.t_end : static_cast<double>(k) * *c.dt;
      if (!(k == 0 || k % c.every == 0 || k == n)) continue;
      s.rotation = SO3d::renormalized(Eigen::Quaterniond(exact.rotation(s.time)));
      s.omega = exact.omega(s.time);
      write_row(out, scene, c.up.normalized(), s, 0);
    }
    return 0;
  };
  if (c.mgl == 0) return emit(exact::FreeBody(J.diagonal(), L0, s0.omega), FreeScene<double>(body));
  if (std::abs(J(0, 0) - J(1, 1)) > 1e-12 * scale)
    throw invalid_input("--scheme exact: no closed form for this top (needs J11 = J22, a Lagrange top)");
  const V3 E = c.com.normalized();
  if ((E - V3::UnitZ()).norm() > 1e-14)
    throw invalid_input("--scheme exact: no closed form for this top (needs --com along the symmetry axis 0,0,1)");
  const HeavyTop<double> scene(body, UniformGravity<double>(c.mgl, c.com, c.up));
  return emit(exact::LagrangeTop(J(0, 0), J(2, 2), c.mgl, L0, s0.omega, c.up.normalized()), scene);
#endif
}

/// The scheme, plain or composed (--order 4 or 6).
template <class Scheme, class Scene, class Out>
int run_scheme(const Config& c, Scheme scheme, const Scene& scene, const trompo::State<double>& s0, Out& out) {
  if constexpr (std::is_same_v<Scheme, trompo::RK4>) {
    return run(trompo::Stepper<Scheme, Scene>(scheme, scene), c, s0, out);
  } else {
    if (c.order == 2) return run(trompo::Stepper<Scheme, Scene>(scheme, scene), c, s0, out);
    if (c.processed) return run(trompo::ProcessedStepper<Scheme, Scene>(scheme, scene), c, s0, out);
    return run(trompo::ComposedStepper<Scheme, Scene>(scheme, scene,
                                                      c.composition ? *c.composition : trompo::composition_of_order(c.order)),
               c, s0, out);
  }
}

// ---- splitting (--scheme splitting) ----
/// The splitting method of --composition, or the default of --order for this scene.
template <class Scene>
trompo::SplittingMethod splitting_method(const Config& c, const Scene& scene) {
  using trompo::SplittingMethod;
  if (!c.composition_name) return trompo::Splitting::default_for(scene, c.order).method;
  for (const auto m : trompo::all_splitting_methods)
    if (*c.composition_name == trompo::to_string(m)) return m;
  throw invalid_input("--composition: unknown splitting method " + *c.composition_name);
}

/// Throws invalid_input (exit 2) for a method or projection the scene does not allow.
template <class Scene>
void check_splitting(const Config& c, const Scene& scene) {
  trompo::Splitting(splitting_method(c, scene)).check(scene);
  if (c.energy_projection && !trompo::detail::splitting_effects_of<Scene>::conservative)
    throw invalid_input("--energy-projection: needs a conservative scene (gravity only): not with --damping, --torque, "
                        "--space-torque or --rotor");
}

template <class Scene, class Out>
int run_splitting(const Config& c, const Scene& scene, const trompo::State<double>& s0, Out& out) {
  using namespace trompo;
  const SplittingMethod m = splitting_method(c, scene);
  check_splitting(c, scene);
  if constexpr (detail::splitting_effects_of<Scene>::conservative)
    if (c.energy_projection) return run(Stepper<SplittingProjected, Scene>(SplittingProjected(m), scene), c, s0, out);
  return run(Stepper<Splitting, Scene>(Splitting(m), scene), c, s0, out);
}
// ---- end splitting ----

template <class Scene, class Out>
int dispatch_scheme(const Config& c, const Scene& scene, const trompo::State<double>& s0, Out& out) {
  using namespace trompo;
  if (c.scheme == "splitting") return run_splitting(c, scene, s0, out);  // splitting
  if (c.scheme == "simo-alpha") return run_scheme(c, SimoAlpha(c.alpha.value_or(0.5)), scene, s0, out);
  if (c.scheme == "simo-collocation") return run_scheme(c, SimoCollocation{}, scene, s0, out);
  if (c.scheme == "simo-kappa") return run_scheme(c, SimoKappa{}, scene, s0, out);
  if (c.scheme == "geradin-bauchau") return run_scheme(c, GeradinBauchau{}, scene, s0, out);
  if (c.scheme == "geradin-bauchau-paper") return run_scheme(c, GeradinBauchauPaper{}, scene, s0, out);
  if (c.scheme == "rk4") return run_scheme(c, RK4{}, scene, s0, out);
  // ---- families (docs/families.md): plain steppers (not composed) ----
  if (c.scheme == "lie-gen-alpha") return run(Stepper<LieGenAlpha, Scene>(LieGenAlpha(c.rho_inf.value_or(0.8)), scene), c, s0, out);
  if constexpr (!Scene::has_applied_torque) {
    if (c.scheme == "constrained-trapezoid")
      return run(Stepper<ConstrainedTrapezoid, Scene>(ConstrainedTrapezoid{}, scene), c, s0, out);
    if constexpr (Scene::potentials_linear) {  // [T12]'s closed form: not the gravity gradient
      if (c.scheme == "energy-decaying") {
        const ChiSchedule schedule = c.chi_schedule.value_or("constant") == "sensor" ? ChiSchedule::sensor : ChiSchedule::constant;
        return run(Stepper<EnergyDecaying, Scene>(EnergyDecaying(c.chi.value_or(0.0), schedule), scene), c, s0, out);
      }
    }
  }
  throw invalid_input("--scheme: unknown scheme '" + c.scheme + "'");
}


// ---- the checks and the scenes (formerly main's body) ----------------------------------

/// Calls f(scene) with the scene simulate() runs for `body` and weight `mgl`. The library
/// compiles in exactly the effects a scene names; the CLI keeps three scenes: the free body
/// (mgl 0: no torque computed at all), the heavy top, and, when any of
/// --damping/--torque/--space-torque/--rotor is given, a scene with all of them (those not
/// given are zero) to keep the number of compiled variants small. `heavy`: a heavy top even
/// at mgl 0 (an ensemble whose members carry their own mgl). simulate(), validate() and
/// validate_member() all choose here, so that a check sees the scene that runs.
template <class F>
decltype(auto) with_scene_of(const Config& c, const trompo::RigidBody<double>& body, double mgl, bool heavy, F&& f) {
  using namespace trompo;
  const UniformGravity<double> gravity(mgl, c.com, c.up);
  if (c.gravity_gradient)  // a satellite (docs/spacecraft.md): its H column is the Jacobi integral
    return f(cases::Satellite<double>(body, GravityGradient<double>(body, *c.gravity_gradient, c.orbit_normal, c.radial)));
  if (c.have_effects)
    return f(Scene<double, UniformGravity<double>, ViscousDamping<double>, ConstantBodyTorque<double>,
                   ConstantSpaceTorque<double>, Rotor<double>>(body, gravity, ViscousDamping<double>(c.damping),
                                                               ConstantBodyTorque<double>(c.body_torque),
                                                               ConstantSpaceTorque<double>(c.space_torque),
                                                               Rotor<double>(c.rotor)));
  if (mgl == 0 && !heavy) return f(FreeScene<double>(body));
  return f(HeavyTop<double>(body, gravity));
}

/// The initial state on its scene, before any row: a rotation vector whose length
/// overflows has no attitude exp(R^) (its quaternion is NaN), and an Omega whose energy H or
/// momentum pi overflows for this inertia has no first row; either would fail the first
/// step as "non-finite". Both are bad input: throws invalid_input naming the field.
template <class Scene>
void check_initial_state(const Scene& scene, const trompo::State<double>& s, const std::string& rotation_field,
                         const std::string& omega_field) {
  if (!s.rotation.unit_quaternion().coeffs().allFinite())
    throw invalid_input(rotation_field + ": the rotation vector's length overflows (no attitude exp(R^)); give it "
                        "modulo 2*pi");
  const double H = scene.energy(s);
  const V3 pi = scene.spatial_momentum(s);
  if (!std::isfinite(H) || !pi.allFinite())
    throw invalid_input(omega_field + ": the initial " + (std::isfinite(H) ? "momentum pi" : "energy H") +
                        " is not finite (overflows for this Omega and inertia)");
}

/// Everything trompo-simulate checks before it writes anything; throws invalid_input.
inline void validate(const Config& c) {
  using namespace trompo;
  State<double> s0;
  const RigidBody<double> body =
      c.unphysical_ok ? RigidBody<double>(c.inertia, allow_unphysical_inertia) : RigidBody<double>(c.inertia);
  s0.rotation = SO3d::exp(c.rotation);
  s0.omega = c.omega;
  s0.validate();
  // Validate the scheme name and the gravity parameters before writing anything.
  if (!known_scheme(c.scheme)) throw invalid_input("--scheme: unknown scheme '" + c.scheme + "'");
  const UniformGravity<double> gravity(c.mgl, c.com, c.up);
  // Effects are validated here too, before any row is written.
  const ViscousDamping<double> damping(c.damping);
  const ConstantBodyTorque<double> body_torque(c.body_torque);
  const ConstantSpaceTorque<double> space_torque(c.space_torque);
  const Rotor<double> rotor(c.rotor);
  (void)gravity, (void)damping, (void)body_torque, (void)space_torque, (void)rotor;
  if (c.gravity_gradient) (void)GravityGradient<double>(body, *c.gravity_gradient, c.orbit_normal, c.radial);
  with_scene_of(c, body, c.mgl, false, [&](const auto& scene) { check_initial_state(scene, s0, "--rotation", "--omega"); });
  // ---- splitting: method and projection against the scene, before any output (an
  // ensemble's members are checked again on their own scenes: validate_member) ----
  if (c.scheme == "splitting")
    with_scene_of(c, body, c.mgl, false, [&](const auto& scene) { check_splitting(c, scene); });
  if (c.scheme == "exact" && !c.ensemble.empty())
    throw invalid_input("--ensemble: not with --scheme exact (the closed forms run one top at a time)");
  if (c.scheme == "exact" && c.have_effects)
    throw invalid_input("--scheme exact: no closed form with damping, torques or a rotor");
  if (c.scheme == "exact" && !body.is_diagonal())
    throw invalid_input("--scheme exact: no closed form for a non-diagonal inertia (give principal axes)");
  if (c.scheme == "exact" && c.mgl != 0 &&
      (std::abs(c.inertia(0, 0) - c.inertia(1, 1)) > 1e-12 * c.inertia.cwiseAbs().maxCoeff() ||
       (c.com.normalized() - V3::UnitZ()).norm() > 1e-14))
    throw invalid_input("--scheme exact: no closed form for this top (needs J11 = J22 and --com 0,0,1: a Lagrange top)");
}

struct EnsembleRun;
inline bool member_weights(const RowSink&) { return false; }
inline bool member_weights(const EnsembleRun& e);
inline int run_exact(const Config& c, const trompo::RigidBody<double>& body, const trompo::State<double>& s0, EnsembleRun& out);

/// Runs a validated Config into `out`: a RowSink (rows of one trajectory) or an
/// EnsembleRun. Returns the CLI's exit status (0 done, 3 a step failed).
template <class Out>
int simulate(const Config& c, Out& out) {
  using namespace trompo;
  const RigidBody<double> body =
      c.unphysical_ok ? RigidBody<double>(c.inertia, allow_unphysical_inertia) : RigidBody<double>(c.inertia);
  State<double> s0;
  s0.rotation = SO3d::exp(c.rotation);
  s0.omega = c.omega;
  if (c.scheme == "exact") return run_exact(c, body, s0, out);
  // The scene of with_scene_of; an ensemble with a per-member mgl is a heavy top even
  // where a member's mgl is 0.
  return with_scene_of(c, body, c.mgl, member_weights(out),
                       [&](const auto& scene) { return dispatch_scheme(c, scene, s0, out); });
}

// ---- ensembles ---------------------------------------------------------------------------

/// The members of an ensemble: initial attitudes (Λ0 = exp(R^) for a rotation vector R, as
/// --rotation) and body angular velocities, and optionally a per-member mgl and inertia
/// (empty: the Config's for every member).
struct EnsembleInput {
  std::vector<trompo::SO3d> rotation;
  std::vector<V3> omega;
  std::vector<double> mgl;
  std::vector<M3> inertia;
  std::size_t size() const { return rotation.size(); }
};

/// An ensemble in place of a RowSink: the members in, their final states out.
struct EnsembleRun {
  const EnsembleInput& input;
  std::vector<trompo::State<double>> states;                 ///< final (or last good) state of each member
  std::vector<trompo::IntegrationSummary<double>> summaries;  ///< what integrate did for each
  std::vector<double> energy;                                 ///< H of the final state, on the member's scene
  std::vector<double> momentum_map;                           ///< μ = up·π
  std::vector<V3> spatial_momentum;                           ///< π
  std::size_t failed() const {
    return static_cast<std::size_t>(std::count_if(summaries.begin(), summaries.end(), [](const auto& s) { return !s.ok(); }));
  }
};

inline bool member_weights(const EnsembleRun& e) { return !e.input.mgl.empty(); }

inline int run_exact(const Config&, const trompo::RigidBody<double>&, const trompo::State<double>&, EnsembleRun&) {
  throw invalid_input("--ensemble: not with --scheme exact (the closed forms run one top at a time)");
}

/// Member i's body: its own inertia or the Config's.
inline trompo::RigidBody<double> member_body(const Config& c, const EnsembleInput& in, std::size_t i) {
  using trompo::RigidBody;
  if (in.inertia.empty())
    return c.unphysical_ok ? RigidBody<double>(c.inertia, trompo::allow_unphysical_inertia) : RigidBody<double>(c.inertia);
  return RigidBody<double>(in.inertia[i]);
}

/// Member i's scene, built as simulate() builds the single run's (same constructors, same
/// arguments): its rows are what `trompo-simulate` gives with that member's flags.
template <class SceneT>
SceneT member_scene(const Config& c, const EnsembleInput& in, std::size_t i) {
  using namespace trompo;
  const RigidBody<double> body = member_body(c, in, i);
  if constexpr (SceneT::is_free) {
    return SceneT(body);
  } else if constexpr (std::is_same_v<SceneT, cases::Satellite<double>>) {  // not reached: parse_flags refuses it
    return SceneT(body, GravityGradient<double>(body, c.gravity_gradient.value_or(0.0), c.orbit_normal, c.radial));
  } else {
    const UniformGravity<double> gravity(in.mgl.empty() ? c.mgl : in.mgl[i], c.com, c.up);
    if constexpr (std::is_same_v<SceneT, HeavyTop<double>>)
      return SceneT(body, gravity);
    else
      return SceneT(body, gravity, ViscousDamping<double>(c.damping), ConstantBodyTorque<double>(c.body_torque),
                    ConstantSpaceTorque<double>(c.space_torque), Rotor<double>(c.rotor));
  }
}

/// Checks member i (finite numbers, a rigid body's inertia, a valid weight, and for
/// --scheme splitting the method on the member's own scene, of the type simulate() runs);
/// throws invalid_input naming the field.
inline void validate_member(const Config& c, const EnsembleInput& in, std::size_t i) {
  using namespace trompo;
  State<double> s;
  s.rotation = in.rotation[i];
  s.omega = in.omega[i];
  s.validate();
  const RigidBody<double> body = member_body(c, in, i);
  const double mgl = in.mgl.empty() ? c.mgl : in.mgl[i];
  const UniformGravity<double> gravity(mgl, c.com, c.up);
  (void)gravity;
  with_scene_of(c, body, mgl, !in.mgl.empty(),
                [&](const auto& scene) { check_initial_state(scene, s, "rotation1,2,3", "omega1,2,3"); });
  if (c.scheme == "splitting")
    with_scene_of(c, body, mgl, !in.mgl.empty(), [&](const auto& scene) { check_splitting(c, scene); });
}

/// The same stepper on member i's scene (of the same type).
template <class Scheme, class SceneT>
trompo::Stepper<Scheme, SceneT> with_scene(const Config&, const trompo::Stepper<Scheme, SceneT>& st, SceneT scene) {
  return trompo::Stepper<Scheme, SceneT>(st.scheme(), std::move(scene), st.options());
}
template <class Scheme, class SceneT>
trompo::ComposedStepper<Scheme, SceneT> with_scene(const Config&, const trompo::ComposedStepper<Scheme, SceneT>& st,
                                                   SceneT scene) {
  return trompo::ComposedStepper<Scheme, SceneT>(st.scheme(), std::move(scene), st.method(), st.options());
}
template <class Scheme, class SceneT>
trompo::ProcessedStepper<Scheme, SceneT> with_scene(const Config&, const trompo::ProcessedStepper<Scheme, SceneT>& st,
                                                    SceneT scene) {
  return trompo::ProcessedStepper<Scheme, SceneT>(st.scheme(), std::move(scene), st.options());
}
/// A splitting stepper on member i's scene: the method of --composition, or the default of
/// --order chosen for this member's body (Chin where its free flow is exact), as the single
/// run with the member's --inertia chooses it, not for the Config's body.
template <bool EnergyProjection, class SceneT>
trompo::Stepper<trompo::SplittingScheme<EnergyProjection>, SceneT> with_scene(
    const Config& c, const trompo::Stepper<trompo::SplittingScheme<EnergyProjection>, SceneT>& st, SceneT scene) {
  const trompo::SplittingScheme<EnergyProjection> scheme(splitting_method(c, scene));
  return trompo::Stepper<trompo::SplittingScheme<EnergyProjection>, SceneT>(scheme, std::move(scene), st.options());
}

/// The ensemble counterpart of run(): every member from t = 0 to t_end by integrate_ensemble
/// (--threads), one shared stepper unless members carry their own mgl or inertia.
template <class StepperT>
int run(const StepperT& stepper, const Config& c, const trompo::State<double>&, EnsembleRun& e) {
  using SceneT = typename StepperT::Scene;
  const EnsembleInput& in = e.input;
  const std::size_t n = in.size();
  e.states.assign(n, trompo::State<double>{});
  for (std::size_t i = 0; i < n; ++i) {
    e.states[i].rotation = in.rotation[i];
    e.states[i].omega = in.omega[i];
  }
  const trompo::EnsembleOptions options{.threads = c.threads};
  std::vector<StepperT> steppers;
  if (in.mgl.empty() && in.inertia.empty()) {
    e.summaries = trompo::integrate_ensemble(stepper, e.states, *c.t_end, *c.dt, options);
  } else {
    steppers.reserve(n);
    for (std::size_t i = 0; i < n; ++i) steppers.push_back(with_scene(c, stepper, member_scene<SceneT>(c, in, i)));
    e.summaries = trompo::integrate_ensemble(steppers, e.states, *c.t_end, *c.dt, options);
  }
  const V3 up = c.up.normalized();
  e.energy.resize(n);
  e.momentum_map.resize(n);
  e.spatial_momentum.resize(n);
  for (std::size_t i = 0; i < n; ++i) {
    const SceneT& scene = steppers.empty() ? stepper.scene() : steppers[i].scene();
    e.spatial_momentum[i] = scene.spatial_momentum(e.states[i]);
    e.energy[i] = scene.energy(e.states[i]);
    e.momentum_map[i] = up.dot(e.spatial_momentum[i]);
  }
  return e.failed() ? 3 : 0;
}

/// The columns an ensemble file may have; the first six are required.
inline const std::vector<std::string>& ensemble_columns() {
  static const std::vector<std::string> names = {"rotation1", "rotation2", "rotation3", "omega1", "omega2", "omega3",
                                                 "mgl",       "J11",       "J22",       "J33",    "J12",    "J13",
                                                 "J23"};
  return names;
}

/// Reads --ensemble FILE: a header line naming the columns (any order; rotation1..3 and
/// omega1..3 required, mgl and J11,J22,J33[,J12,J13,J23] optional), then one member per
/// line; blank lines and lines starting with '#' are skipped. Every member is validated.
/// Throws invalid_input naming the file, the line and the reason.
inline EnsembleInput read_ensemble(const Config& c) {
  const std::string& path = c.ensemble;
  std::ifstream file(path);
  if (!file) throw invalid_input("--ensemble: cannot open '" + path + "': " + std::strerror(errno));
  const auto& known = ensemble_columns();
  std::vector<int> column_of;  // index into `known` for each column of the file
  std::vector<bool> seen(known.size(), false);
  EnsembleInput in;
  std::string line;
  long line_no = 0;
  auto where = [&] { return "--ensemble: " + path + ":" + std::to_string(line_no) + ": "; };
  auto split = [](const std::string& text) {
    std::vector<std::string> fields;
    std::stringstream ss(text);
    std::string f;
    while (std::getline(ss, f, ',')) {
      const auto b = f.find_first_not_of(" \t\r"), e = f.find_last_not_of(" \t\r");
      fields.push_back(b == std::string::npos ? std::string() : f.substr(b, e - b + 1));
    }
    if (!text.empty() && text.back() == ',') fields.emplace_back();
    return fields;
  };
  while (std::getline(file, line)) {
    ++line_no;
    if (line.find_first_not_of(" \t\r") == std::string::npos || line[line.find_first_not_of(" \t\r")] == '#') continue;
    const auto fields = split(line);
    if (column_of.empty()) {  // the header
      for (const auto& name : fields) {
        const auto it = std::find(known.begin(), known.end(), name);
        if (it == known.end())
          throw invalid_input(where() + "unknown column '" + name +
                              "' (rotation1,rotation2,rotation3,omega1,omega2,omega3[,mgl][,J11,J22,J33[,J12,J13,J23]])");
        const auto k = static_cast<std::size_t>(it - known.begin());
        if (seen[k]) throw invalid_input(where() + "column '" + name + "' given twice");
        seen[k] = true;
        column_of.push_back(static_cast<int>(k));
      }
      for (std::size_t k = 0; k < 6; ++k)
        if (!seen[k]) throw invalid_input(where() + "missing column '" + known[k] + "' in the header");
      const bool diag = seen[7] || seen[8] || seen[9], off = seen[10] || seen[11] || seen[12];
      if ((diag && !(seen[7] && seen[8] && seen[9])) || (off && !(seen[10] && seen[11] && seen[12])) || (off && !diag))
        throw invalid_input(where() + "inertia columns must be J11,J22,J33 or all six J11..J23");
      continue;
    }
    if (fields.size() != column_of.size())
      throw invalid_input(where() + "expected " + std::to_string(column_of.size()) + " fields, got " +
                          std::to_string(fields.size()));
    double v[13] = {0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0};
    for (std::size_t f = 0; f < fields.size(); ++f) {
      const auto k = static_cast<std::size_t>(column_of[f]);
      v[k] = parse_number(where() + known[k], fields[f]);
    }
    in.rotation.push_back(trompo::SO3d::exp(V3(v[0], v[1], v[2])));
    in.omega.emplace_back(v[3], v[4], v[5]);
    if (seen[6]) in.mgl.push_back(v[6]);
    if (seen[7]) {
      M3 J = M3::Zero();
      J.diagonal() << v[7], v[8], v[9];
      J(0, 1) = J(1, 0) = v[10];
      J(0, 2) = J(2, 0) = v[11];
      J(1, 2) = J(2, 1) = v[12];
      in.inertia.push_back(J);
    }
    try {
      validate_member(c, in, in.size() - 1);
    } catch (const invalid_input& e) {
      throw invalid_input(where() + e.what());
    }
  }
  if (column_of.empty()) throw invalid_input("--ensemble: " + path + ": no header line");
  if (in.size() == 0) throw invalid_input("--ensemble: " + path + ": no members (only a header)");
  return in;
}

/// The ensemble's CSV: one row per member, its final (or last good) state in the columns
/// of kHeader (iterations: the member's total), between its index and its status.
inline void write_ensemble(std::FILE* out, const EnsembleRun& e) {
  std::fputs("member,t,R00,R01,R02,R10,R11,R12,R20,R21,R22,W1,W2,W3,H,mu,pi1,pi2,pi3,iterations,status\n", out);
  for (std::size_t i = 0; i < e.states.size(); ++i) {
    const auto& s = e.states[i];
    const M3 R = s.rotation.matrix();
    const V3& pi = e.spatial_momentum[i];
    std::fprintf(out, "%zu,%.17g", i, s.time);
    for (int r = 0; r < 3; ++r)
      for (int k = 0; k < 3; ++k) std::fprintf(out, ",%.17g", R(r, k));
    std::fprintf(out, ",%.17g,%.17g,%.17g,%.17g,%.17g,%.17g,%.17g,%.17g,%lld,%s\n", s.omega.x(), s.omega.y(),
                 s.omega.z(), e.energy[i], e.momentum_map[i], pi.x(), pi.y(), pi.z(),
                 static_cast<long long>(e.summaries[i].iterations), e.summaries[i].reason());
  }
}

}  // namespace trompo_simulate
