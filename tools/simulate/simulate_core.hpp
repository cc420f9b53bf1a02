#pragma once
// The logic of trompo-simulate, shared by the CLI (tools/simulate/trompo_simulate.cpp) and the
// Python module (python/trompo_module.cpp): the Config and its flag parser (parse,
// parse_flags), the checks made before anything is written (validate), the scene and
// scheme dispatch (simulate) and the rows, which go to a RowSink: a CSV file for the CLI,
// NumPy arrays for Python. Both faces therefore compute every row by the same code and
// give bit-identical numbers.
//
// This header is the interface; the engine (the dispatch over the scheme registry,
// include/trompo/schemes/registry.hpp, and every stepper it instantiates) is compiled once,
// in simulate_core.cpp, into the static library trompo_simulate_core that both link.
//
// Ensembles (--ensemble FILE, trompo.ensemble): the same dispatch with an EnsembleRun in
// place of the sink; simulate() then integrates every member with trompo::integrate_ensemble
// (include/trompo/drivers/ensemble.hpp) and keeps each member's final state.
//
// Not part of the library (include/trompo): an application of it.
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <functional>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include <algorithm>
#include <fstream>
#include <iterator>
#include <limits>
#include <sstream>
#include <type_traits>
#include <utility>
#if __has_include(<unistd.h>)
#include <unistd.h>
#define TROMPO_SIMULATE_HAVE_ISATTY 1
#endif

#include "trompo/drivers/adaptive.hpp"
#include "trompo/drivers/integrate.hpp"
#include "trompo/drivers/sampled.hpp"
#include "trompo/model/cases.hpp"
#include "trompo/schemes/registry.hpp"
#include "trompo/steppers/composition.hpp"

namespace trompo_simulate {

using trompo::invalid_input;
using V3 = Eigen::Vector3d;
using M3 = Eigen::Matrix3d;

/// The names --scheme takes: every registered scheme, and the closed forms ("exact").
inline std::string scheme_names() {
  std::string names;
  trompo::RegisteredSchemes::for_each([&](auto entry) { names += std::string(decltype(entry)::type::name) + "|"; });
  return names + "exact";
}

/// trompo-simulate --help after the scheme line.
constexpr const char* kUsageFlags =
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
    "  --progress-after S           stderr a terminal: progress lines after S seconds of a fixed-step\n"
    "                               run, then once a second (default 3)\n"
    // ---- adaptive steps (docs/adaptive.md) ----
    "  --rtol R [--atol A]          adaptive steps to tolerances R, A (default A 1e-6; R below 100 eps is raised\n"
    "                               to it); --dt, optional, is the first step; without --scheme, --order and\n"
    "                               --composition the method is picked for the scene (docs/adaptive.md)\n"
    "  --control tolerance|reversible   error estimate + PI control (default), or Hairer-Soderlind's\n"
    "                               time-reversible step density (conservative scenes, long runs)\n"
    "  --tol-scope span|time        the tolerances bound the end error of the run (default), or the\n"
    "                               error per unit time (the end error then grows like tol*t)\n"
    "  --estimate automatic|defect|richardson|doubling   tolerance mode's error estimate (default\n"
    "                               automatic: Richardson's for the splitting, else the interpolant's\n"
    "                               defect up to order 6 and step doubling above)\n"
    "  --substeps M                 Richardson's estimate: steps per attempt, 2..16 (default 8)\n"
    "  --t-eval T1,T2,...|@FILE     rows at exactly these times (dense output), and only these\n"
    "  --event NAME[:terminal[:N]]  nutation-max|nutation-min|axis-crossing|flip (repeatable)\n"
    "  --event-csv FILE             one row per event: event, then the usual columns\n"
    // ---- control in the loop (docs/control.md) ----
    "  control in the loop (fixed steps of --dt between the samples; schemes that carry wheels:\n"
    "  simo-kappa, simo-collocation, simo-alpha, rk4 and their compositions):\n"
    "  --wheels FILE                reaction wheels: CSV with header gx,gy,gz,Js,speed0,max_torque,max_speed\n"
    "                               (axis in body axes, axial inertia, initial speed relative to the body in\n"
    "                               rad/s, limits in N m and rad/s, 'inf' for none); --inertia is then the\n"
    "                               whole spacecraft's; adds columns wheel1..N (speeds) and u1..N (motor\n"
    "                               torques held from the row on)\n"
    "  --controller mrp-pd:K,P|bdot:k   sampled every --control-period T seconds (zero-order hold):\n"
    "                               mrp-pd: L = -K sigma - P Omega to --target-rotation, on the wheels\n"
    "                               (axes spanning 3-D) or, without --wheels, as a body torque;\n"
    "                               bdot: m = -k dB/dt on magnetorquers (needs --orbit-radius)\n"
    "  --control-period T           the sample period (> 0, at least |--dt|); required with --controller\n"
    "  --target-rotation R1,R2,R3   mrp-pd's inertial target as a rotation vector, as --rotation (default 0)\n"
    "  --orbit-radius M             magnetorquers in the Earth's field (centred dipole, IGRF-13 2020.0)\n"
    "                               along a circular orbit of radius M metres\n"
    "  --orbit-inclination DEG      with --orbit-radius: inclination in degrees (default 0)\n"
    "  --max-dipole X               with --orbit-radius: dipole limit per axis, A m^2 (default none)\n";

// ---- control in the loop (--wheels, --controller, --control-period, field flags) ----
/// The control flags (docs/cli.md); `on()` when any is given.
struct ControlFlags {
  std::string wheels_file;                     ///< --wheels FILE
  std::vector<trompo::Wheel<double>> wheels;   ///< its wheels, validated
  std::optional<double> period;                ///< --control-period
  std::string controller;                      ///< --controller NAME ("" none, "mrp-pd", "bdot")
  double K = 0, P = 0, k = 0;                  ///< the controller's gains
  std::optional<V3> target;                    ///< --target-rotation (rotation vector)
  std::optional<double> orbit_radius;          ///< --orbit-radius (m): a magnetic field
  std::optional<double> inclination_deg;       ///< --orbit-inclination (degrees)
  std::optional<double> max_dipole;            ///< --max-dipole (A m^2 per axis)
  /// --controller code: a controller given as code, not as a flag (the Python module's
  /// trompo.control with a callable); the CLI has none to give, and refuses it.
  std::function<trompo::Command<double>(const trompo::Sample<double>&)> code;
  /// mrp-pd's target as a matrix (the Python module's trompo.MrpPd(target=...)), in place
  /// of --target-rotation's rotation vector: no round trip through the logarithm.
  std::optional<M3> target_matrix;
  /// Whether the run is a control run (one scene type for all of them, simulate_core.cpp).
  bool on() const {
    return !wheels_file.empty() || !controller.empty() || period || target || orbit_radius || inclination_deg || max_dipole;
  }
};

/// The one scene of every control run: wheels (maybe none), a held body torque (zero unless
/// mrp-pd runs without wheels) and magnetorquers (zero dipole without --orbit-radius).
using ControlScene = trompo::Scene<double, trompo::ReactionWheels<double>, trompo::HeldBodyTorque<double>,
                                   trompo::Magnetorquer<double>>;
// ---- end control ----

// ---- adaptive steps (--rtol, --atol, --control, --t-eval, --event, --event-csv) ----
/// The adaptive flags (docs/adaptive.md); `on` when --rtol is given.
struct AdaptiveFlags {
  bool on = false;
  double rtol = 1e-3, atol = 1e-6;  ///< SciPy's defaults (--rtol is required to switch on)
  std::string control = "tolerance";
  std::string tol_scope = "span";      ///< --tol-scope span|time
  std::string estimate = "automatic";  ///< --estimate automatic|defect|richardson|doubling
  int substeps = 0;                    ///< --substeps M (0: automatic)
  std::vector<double> t_eval;                         ///< --t-eval: rows at exactly these times
  std::vector<std::pair<std::string, int>> events;  ///< --event NAME[:terminal[:N]]: name, terminal count
  std::string event_csv;                             ///< --event-csv FILE
  /// --rtol as given when it lay below kRtolFloor (rtol is then raised to it; the run warns).
  std::optional<double> rtol_asked;
  /// The method was picked by pick_adaptive_method (no --scheme, --order or --composition):
  /// the summary line says so.
  bool picked = false;
  /// Events given as code, after --event's (no flag: the Python module's callables,
  /// solve_ivp(events=[f, ...])); their rows go to --event-csv under their names.
  std::vector<trompo::Event<double>> code_events;
};
// ---- end adaptive ----

/// trompo-simulate --help.
inline std::string usage() {
  return "usage: trompo-simulate [options]\n"
         "  --case ht0|ht1|ht2|fb1|fb2|sat1|sat2   preset from docs/theory.md §7-8 and docs/spacecraft.md\n"
         "                               (other flags override it)\n"
         "  --scheme " + scheme_names() + "\n" + kUsageFlags;
}

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
  /// The initial attitude as a matrix (body -> space), in place of --rotation: the Python
  /// module's trompo.initial_state, so that a matrix or quaternion goes in unrounded.
  std::optional<M3> rotation_matrix;
  V3 omega = V3::Zero();
  std::optional<double> dt;
  std::optional<double> t_end;
  long every = 1;
  /// Progress lines (stderr a terminal) begin after this many seconds of a fixed-step run
  /// (--progress-after; 0: from the first 4096 steps, which makes the CLI's test timing-free).
  double progress_after = 3.0;
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
  ControlFlags control;                     ///< --wheels, --controller, … (control in the loop)
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

/// Whether `name` is a --scheme the CLI runs: a registered scheme, or "exact".
inline bool known_scheme(const std::string& name) { return name == "exact" || trompo::RegisteredSchemes::contains(name); }

/// How the CLI composes --scheme `name` (the registry's entry; the closed forms: not at all).
inline trompo::Compositions compositions_of(const std::string& name) {
  trompo::Compositions how = trompo::Compositions::none;
  trompo::RegisteredSchemes::visit(name, [&](auto entry) { how = decltype(entry)::type::compositions; });
  return how;
}

/// Which scenes --scheme `name` steps (the registry's entry).
inline trompo::Scenes scenes_of(const std::string& name) {
  trompo::Scenes scenes = trompo::Scenes::all;
  trompo::RegisteredSchemes::visit(name, [&](auto entry) { scenes = decltype(entry)::type::scenes; });
  return scenes;
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
  } else if (flag == "--tol-scope") {
    a.tol_scope = value;
  } else if (flag == "--estimate") {
    a.estimate = value;
  } else if (flag == "--substeps") {
    const double m = parse_number(flag, value);
    constexpr int most = trompo::AdaptiveOptions<double>::max_substeps;
    if (!(m >= 2 && m <= most && m == std::floor(m)))
      throw invalid_input("--substeps: must be an integer in [2, " + std::to_string(most) + "], got " + value);
    a.substeps = static_cast<int>(m);
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
inline void check_adaptive(Config& c, const std::map<std::string, std::string>& flags);

/// SciPy's floor on rtol, 100 ε: below it the steps' round-off is as large as the error asked
/// for. A smaller --rtol is raised to it with a warning (as SciPy's solve_ivp does), so that
/// a run asked for "as exact as possible" still runs, and says what it delivers.
constexpr double kRtolFloor = 100 * std::numeric_limits<double>::epsilon();

/// The method of an adaptive run given no --scheme, --order or --composition: the cheapest
/// at equal end error in the measurements of docs/adaptive.md ("The method an adaptive run
/// picks"), where the rule's table is. The splitting (explicit and spin-exact: no Newton
/// iteration, an error set by the load, not the spin) with the reversible control: 6-50x
/// cheaper than Simo-kappa at order 6 on every scene and tolerance measured (tops, the free
/// body, damping, torques, a rotor, a satellite), its end error 0.002-2.5x the tolerance,
/// where the tolerance control's local errors add up to 20-50x on the Lagrange tops. Order 6
/// (Chin's triple jump where the free flow is exact, else Kahan-Li-9: Splitting::default_for),
/// but order 2 on the free body without effects, whose flow the splitting takes exactly (any
/// order is round-off there, and Strang's step is the cheapest). The reversible control's
/// ε comes from a pilot of 20 tolerance-control attempts: with Richardson's m = 2 (3 steps
/// per attempt, not 9) it costs 20-25 % less of a whole run at 1e-8, the end error still
/// 0.3-1x the tolerance. `control_given`: a --control, --tol-scope, --estimate or --substeps
/// was given (the tolerance control's own flags): the control stays as asked.
inline void pick_adaptive_method(Config& c, bool control_given) {
  const bool free_body = !c.have_effects && c.mgl == 0 && !c.gravity_gradient;
  c.scheme = "splitting";
  c.order = free_body ? 2 : 6;
  if (!control_given) {
    c.adaptive.control = "reversible";
    c.adaptive.substeps = 2;
  }
  c.adaptive.picked = true;
}
// ---- end adaptive ----

// ---- control in the loop: the flags ----
/// Reads --wheels FILE: the header gx,gy,gz,Js,speed0,max_torque,max_speed, then one wheel a
/// line (blank lines and '#' lines skipped); limits may be 'inf'. Throws invalid_input naming
/// the file, the line and the field.
inline std::vector<trompo::Wheel<double>> read_wheels(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw invalid_input("--wheels: cannot open '" + path + "': " + std::strerror(errno));
  static const char* const names[7] = {"gx", "gy", "gz", "Js", "speed0", "max_torque", "max_speed"};
  std::vector<trompo::Wheel<double>> wheels;
  trompo::ReactionWheels<double> check;
  std::string line;
  long line_no = 0;
  bool header = false;
  while (std::getline(in, line)) {
    ++line_no;
    const auto first = line.find_first_not_of(" \t\r");
    if (first == std::string::npos || line[first] == '#') continue;
    std::vector<std::string> fields;
    std::stringstream ss(line);
    std::string f;
    while (std::getline(ss, f, ',')) {
      const auto b = f.find_first_not_of(" \t\r"), e = f.find_last_not_of(" \t\r");
      fields.push_back(b == std::string::npos ? std::string() : f.substr(b, e - b + 1));
    }
    if (!line.empty() && line.back() == ',') fields.emplace_back();
    const std::string where = "--wheels: " + path + ":" + std::to_string(line_no) + ": ";
    if (!header) {
      bool same = fields.size() == 7;
      for (std::size_t i = 0; same && i < 7; ++i) same = fields[i] == names[i];
      if (!same) throw invalid_input(where + "expected the header gx,gy,gz,Js,speed0,max_torque,max_speed");
      header = true;
      continue;
    }
    if (fields.size() != 7) throw invalid_input(where + "expected 7 fields, got " + std::to_string(fields.size()));
    double v[7];
    for (int i = 0; i < 7; ++i) {
      if (i >= 5 && (fields[i] == "inf" || fields[i] == "Inf" || fields[i] == "INF"))
        v[i] = std::numeric_limits<double>::infinity();
      else
        v[i] = parse_number(where + names[i], fields[i]);
    }
    trompo::Wheel<double> w{.axis = V3(v[0], v[1], v[2]), .inertia = v[3], .speed0 = v[4], .max_torque = v[5], .max_speed = v[6]};
    try {
      check.add_wheel(w);  // the library's checks, naming the field (axis, Js, …)
    } catch (const invalid_input& e) {
      throw invalid_input(where + e.what());
    }
    wheels.push_back(w);
  }
  if (!header) throw invalid_input("--wheels: " + path + ": no header line");
  if (wheels.empty()) throw invalid_input("--wheels: " + path + ": no wheels (only a header)");
  return wheels;
}

/// Reads one control flag into `k`; false if `flag` is not one of them.
inline bool parse_control_flag(const std::string& flag, const std::string& value, ControlFlags& k) {
  if (flag == "--wheels") {
    k.wheels_file = value;
    k.wheels = read_wheels(value);
  } else if (flag == "--control-period") {
    k.period = parse_number(flag, value);
  } else if (flag == "--controller") {
    const auto colon = value.find(':');
    const std::string name = value.substr(0, colon);
    const std::string args = colon == std::string::npos ? std::string() : value.substr(colon + 1);
    if (name == "mrp-pd") {
      const auto g = colon == std::string::npos ? std::vector<double>{} : parse_list(flag + " mrp-pd", args);
      if (g.size() != 2) throw invalid_input("--controller mrp-pd: expected mrp-pd:K,P, got '" + value + "'");
      if (!(g[0] >= 0 && g[1] >= 0)) throw invalid_input("--controller mrp-pd: K and P must be >= 0, got '" + value + "'");
      k.K = g[0];
      k.P = g[1];
    } else if (name == "bdot") {
      if (colon == std::string::npos) throw invalid_input("--controller bdot: expected bdot:k, got '" + value + "'");
      k.k = parse_number(flag + " bdot: k", args);
      if (!(k.k >= 0)) throw invalid_input("--controller bdot: k must be >= 0, got '" + value + "'");
    } else if (name == "code" && colon == std::string::npos) {
      // A controller given as code (ControlFlags::code): the Python module's; without it
      // make_controller refuses the run.
    } else {
      throw invalid_input("--controller: unknown controller '" + name + "' (mrp-pd:K,P or bdot:k)");
    }
    k.controller = name;
  } else if (flag == "--target-rotation") {
    k.target = parse_vector(flag, value);
  } else if (flag == "--orbit-radius") {
    k.orbit_radius = parse_number(flag, value);
    if (!(*k.orbit_radius > 0)) throw invalid_input("--orbit-radius: must be > 0 (m), got " + value);
  } else if (flag == "--orbit-inclination") {
    k.inclination_deg = parse_number(flag, value);
  } else if (flag == "--max-dipole") {
    k.max_dipole = parse_number(flag, value);
    if (!(*k.max_dipole > 0)) throw invalid_input("--max-dipole: must be > 0 (A m^2), got " + value);
  } else {
    return false;
  }
  return true;
}

/// Whether --scheme `name` steps the control scene (a scheme that carries wheels).
inline bool steps_control_scene(const std::string& name) {
  bool ok = false;
  trompo::RegisteredSchemes::visit(name, [&](auto entry) { ok = decltype(entry)::type::template steps<ControlScene>; });
  return ok;
}

/// The schemes that step the control scene, for the messages.
inline std::string control_scheme_names() {
  std::string names;
  trompo::RegisteredSchemes::for_each([&](auto entry) {
    using E = typename decltype(entry)::type;
    if constexpr (E::template steps<ControlScene>) names += std::string(names.empty() ? "" : ", ") + E::name;
  });
  return names;
}

/// The checks of the control flags (exit 2 naming the field), after parse_flags' own.
inline void check_control(const Config& c, const std::map<std::string, std::string>& flags) {
  const ControlFlags& k = c.control;
  if (!k.on()) return;
  // The flag that made this a control run, for the messages.
  std::string by;
  for (const char* f : {"--wheels", "--controller", "--control-period", "--target-rotation", "--orbit-radius",
                        "--orbit-inclination", "--max-dipole"})
    if (by.empty() && flags.count(f)) by = f;
  if (!steps_control_scene(c.scheme))
    throw invalid_input("--scheme " + c.scheme + ": cannot carry reaction wheels, so it runs no " + by +
                        " (control runs: " + control_scheme_names() + ")");
  if (c.mgl != 0 || c.have_effects || c.gravity_gradient)
    throw invalid_input(by + ": a control run's scene has wheels, a held torque and magnetorquers only (no --mgl, "
                             "--damping, --torque, --space-torque, --rotor or --gravity-gradient)");
  if (!c.ensemble.empty()) throw invalid_input(by + ": not with --ensemble");
  if (c.adaptive.on) throw invalid_input("--rtol: not with " + by + " (fixed steps of --dt between the samples)");
  if (c.processed) throw invalid_input("--composition blanes-casas-murua-13: not with " + by);
  if (!k.controller.empty() && !k.period) throw invalid_input("--controller: needs --control-period");
  if (k.period && k.controller.empty()) throw invalid_input("--control-period: needs --controller");
  if (k.period && !(*k.period > 0)) throw invalid_input("--control-period: must be > 0, got " + flags.at("--control-period"));
  if (k.period && *k.period < std::abs(*c.dt))
    throw invalid_input("--control-period: " + flags.at("--control-period") + " is shorter than the step --dt " +
                        std::to_string(std::abs(*c.dt)));
  if (k.target && k.controller != "mrp-pd") throw invalid_input("--target-rotation: only with --controller mrp-pd");
  if (!k.orbit_radius && (k.inclination_deg || k.max_dipole))
    throw invalid_input(std::string(k.inclination_deg ? "--orbit-inclination" : "--max-dipole") + ": only with --orbit-radius");
  if (k.controller == "bdot" && !k.orbit_radius)
    throw invalid_input("--controller bdot: needs the magnetic field (give --orbit-radius, and --max-dipole)");
  if (k.controller == "mrp-pd" && !k.wheels.empty()) {
    trompo::ReactionWheels<double> rw;
    for (const auto& w : k.wheels) rw.add_wheel(w);
    const M3 GGt = rw.axes() * rw.axes().transpose();
    const Eigen::SelfAdjointEigenSolver<M3> eig(GGt, Eigen::EigenvaluesOnly);
    int rank = 0;
    for (int i = 0; i < 3; ++i) rank += eig.eigenvalues()(i) > 1e-10 * eig.eigenvalues().maxCoeff();
    if (rank < 3)
      throw invalid_input("--wheels: the wheel axes span " + std::to_string(rank) +
                          " dimension(s) (rank of G_s < 3): --controller mrp-pd needs axes that span 3-D");
  }
}
// ---- end control ----

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
    } else if (flag == "--progress-after") {
      const double a = parse_number(flag, value);
      if (!(a >= 0) || !std::isfinite(a)) throw invalid_input("--progress-after: must be a finite number of seconds >= 0, got " + value);
      c.progress_after = a;
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
    else if (parse_control_flag(flag, value, c.control)) continue;     // control in the loop
    else throw invalid_input("unknown option '" + flag + "' (see --help)");
  }
  if (c.adaptive.on && !flags.count("--scheme") && !flags.count("--order") && !flags.count("--composition") &&
      !c.control.on() && c.ensemble.empty())  // (both refuse --rtol, below)
    pick_adaptive_method(c, flags.count("--control") || flags.count("--tol-scope") || flags.count("--estimate") ||
                                flags.count("--substeps"));  // the tolerance control's own flags
  // The scheme name before any check of a per-scheme flag (--alpha, --rho-inf, …): those
  // checks name the scheme they need, which misleads when the name itself is a typo.
  if (!known_scheme(c.scheme)) throw invalid_input("--scheme: unknown scheme '" + c.scheme + "'");
  if (!c.have_inertia) throw invalid_input("--inertia: required (or give --case)");
  // Adaptive steps choose their own first step (the driver's rule, docs/adaptive.md).
  if (!c.dt && !c.adaptive.on) throw invalid_input("--dt: required (or give --case, or --rtol for adaptive steps)");
  if (!c.t_end) throw invalid_input("--t-end: required (or give --case)");
  if (c.dt && *c.dt == 0) throw invalid_input("--dt: must be non-zero, got 0");
  if (c.dt && *c.t_end != 0 && (*c.t_end > 0) != (*c.dt > 0))
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
  if (scenes_of(c.scheme) == trompo::Scenes::free_body && (c.have_effects || c.mgl != 0))
    throw invalid_input("--scheme " + c.scheme + ": the free body only (--mgl 0, no --damping, --torque, --space-torque or --rotor)");
  if (scenes_of(c.scheme) != trompo::Scenes::all && c.have_effects)
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
    check_control(c, flags);   // control in the loop: refuses the splitting (no wheels)
    check_adaptive(c, flags);  // adaptive steps (before this return, the splitting skipped them)
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
  // ---- schemes the registry does not let the CLI compose (the families, rk4) ----
  if (c.order != 2 && compositions_of(c.scheme) == trompo::Compositions::none) {
    if (c.scheme == "exact")
      throw invalid_input(composed_by + ": order " + std::to_string(c.order) + " needs a symmetric implicit scheme, not exact");
    throw invalid_input(composed_by + ": order " + std::to_string(c.order) + " needs a symmetric scheme; " + c.scheme +
                        " is not composed by the CLI");
  }
  if (c.order != 2 && c.scheme == "simo-alpha" && c.alpha && *c.alpha != 0.5)
    throw invalid_input(composed_by + ": simo-alpha is symmetric only for alpha = 0.5");
  if (c.alpha && !(*c.alpha >= 0 && *c.alpha <= 1)) throw invalid_input("--alpha: must be in [0, 1], got " + std::to_string(*c.alpha));
  check_control(c, flags);  // control in the loop
  if (!c.ensemble.empty())
    for (const char* f : {"--rotation", "--omega", "--every"})
      if (flags.count(f)) throw invalid_input(std::string("--ensemble: the initial states come from the file; drop ") + f);
  check_adaptive(c, flags);  // adaptive steps
  return c;
}

/// The checks of the adaptive flags (exit 2 with the reason), after parse_flags' own.
inline void check_adaptive(Config& c, const std::map<std::string, std::string>& flags) {
  AdaptiveFlags& a = c.adaptive;
  if (!a.on) {
    for (const char* f : {"--atol", "--control", "--tol-scope", "--estimate", "--substeps", "--t-eval", "--event", "--event-csv"})
      if (flags.count(f)) throw invalid_input(std::string(f) + ": only with adaptive steps (give --rtol)");
    return;
  }
  if (!(std::isfinite(a.rtol) && a.rtol > 0)) throw invalid_input("--rtol: must be finite and > 0, got " + flags.at("--rtol"));
  if (!(std::isfinite(a.atol) && a.atol >= 0)) throw invalid_input("--atol: must be finite and >= 0, got " + flags.at("--atol"));
  if (a.rtol < kRtolFloor) {  // run_adaptive warns
    a.rtol_asked = a.rtol;
    a.rtol = kRtolFloor;
  }
  if (a.control != "tolerance" && a.control != "reversible")
    throw invalid_input("--control: must be tolerance or reversible, got '" + a.control + "'");
  if (a.tol_scope != "span" && a.tol_scope != "time")
    throw invalid_input("--tol-scope: must be span or time, got '" + a.tol_scope + "'");
  if (a.estimate != "automatic" && a.estimate != "defect" && a.estimate != "richardson" && a.estimate != "doubling")
    throw invalid_input("--estimate: must be automatic, defect, richardson or doubling, got '" + a.estimate + "'");
  if (flags.count("--substeps") && a.estimate == "defect")
    throw invalid_input("--substeps: Richardson's steps per attempt; --estimate defect takes none");
  if (flags.count("--substeps") && a.estimate == "doubling" && a.substeps != 2)
    throw invalid_input("--substeps: --estimate doubling takes 2, got " + flags.at("--substeps"));
  if (!c.ensemble.empty()) throw invalid_input("--rtol: adaptive steps are not available with --ensemble");
  if (c.scheme == "exact") throw invalid_input("--rtol: --scheme exact has no steps to adapt (use --t-eval with a scheme)");
  if (c.processed)
    throw invalid_input("--rtol: the processed composition's processor is tied to h (each change of h costs 24 base "
                        "steps): use --order 6 (Kahan-Li) for adaptive steps, or drop --rtol");
  if (!a.t_eval.empty() && flags.count("--every")) throw invalid_input("--every: not with --t-eval (rows at those times only)");
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
      std::fputs(usage().c_str(), stdout);
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
  /// A control run's header: kHeader's columns, then wheel1..N and u1..N (N = `wheels`).
  /// By default only N = 0 (the plain header); the CLI's sink writes the wheel columns.
  virtual void wheel_header(int wheels) {
    if (wheels != 0) throw invalid_input("--wheels: this output has no wheel columns (use the CLI)");
    header();
  }
  /// A control run's row: row()'s values, then the N wheel speeds (rad/s, relative to the
  /// body) and the N motor torques held from this row on (N m).
  virtual void wheel_row(double t, const M3& R, const V3& W, double H, double mu, const V3& pi, long iterations,
                         const double* /*speeds*/, const double* /*torques*/, int wheels) {
    if (wheels != 0) throw invalid_input("--wheels: this output has no wheel columns (use the CLI)");
    row(t, R, W, H, mu, pi, iterations);
  }
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
  void wheel_header(int wheels) override {
    std::string h(kHeader, std::strlen(kHeader) - 1);  // without the newline
    for (int i = 1; i <= wheels; ++i) h += ",wheel" + std::to_string(i);
    for (int i = 1; i <= wheels; ++i) h += ",u" + std::to_string(i);
    std::fprintf(out_, "%s\n", h.c_str());
  }
  void wheel_row(double t, const M3& R, const V3& W, double H, double mu, const V3& pi, long iterations,
                 const double* speeds, const double* torques, int wheels) override {
    std::fprintf(out_, "%.17g", t);
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) std::fprintf(out_, ",%.17g", R(i, j));
    std::fprintf(out_, ",%.17g,%.17g,%.17g,%.17g,%.17g,%.17g,%.17g,%.17g,%ld", W.x(), W.y(), W.z(), H, mu, pi.x(),
                 pi.y(), pi.z(), iterations);
    for (int i = 0; i < wheels; ++i) std::fprintf(out_, ",%.17g", speeds[i]);
    for (int i = 0; i < wheels; ++i) std::fprintf(out_, ",%.17g", torques[i]);
    std::fputc('\n', out_);
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

// ---- the engine (simulate_core.cpp) --------------------------------------------------------

/// Everything trompo-simulate checks before it writes anything; throws invalid_input.
void validate(const Config& c);

/// Runs a validated Config into `out`, the rows of one trajectory. Returns the CLI's exit
/// status (0 done, 3 a step failed).
int simulate(const Config& c, RowSink& out);

/// Runs a validated Config over every member of `e.input` (--ensemble), keeping each final
/// state. Returns 0, or 3 if a member failed.
int simulate(const Config& c, EnsembleRun& e);

/// Checks member i (finite numbers, a rigid body's inertia, a valid weight, and for
/// --scheme splitting the method on the member's own scene, of the type simulate() runs);
/// throws invalid_input naming the field.
void validate_member(const Config& c, const EnsembleInput& in, std::size_t i);

/// Reads --ensemble FILE: a header line naming the columns (any order; rotation1..3 and
/// omega1..3 required, mgl and J11,J22,J33[,J12,J13,J23] optional), then one member per
/// line; blank lines and lines starting with '#' are skipped. Every member is validated.
/// Throws invalid_input naming the file, the line and the reason.
EnsembleInput read_ensemble(const Config& c);

/// The ensemble's CSV: one row per member, its final (or last good) state in the columns
/// of kHeader (iterations: the member's total), between its index and its status.
void write_ensemble(std::FILE* out, const EnsembleRun& e);


}  // namespace trompo_simulate
