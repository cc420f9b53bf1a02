#pragma once
// The logic of trompo-simulate, shared by the CLI (tools/simulate/trompo_simulate.cpp) and the
// Python module (python/trompo_module.cpp): the Config and its flag parser (parse,
// parse_flags: flags.cpp, on CLI11, one declaration per flag with its check and help line,
// then the checks across flags), the checks made before anything is written (validate), the scene and
// scheme dispatch (simulate) and the rows, which go to a RowSink: a CSV file for the CLI,
// NumPy arrays for Python. Both faces therefore compute every row by the same code and
// give bit-identical numbers.
//
// This header is the interface; the engine (the dispatch over the scheme registry,
// include/trompo/schemes/registry.hpp, and every stepper it instantiates) is compiled once,
// in simulate_core.cpp, and the command line in flags.cpp, into the static library
// trompo_simulate_core that both link (neither this header nor the library sees CLI11).
//
// Ensembles (--ensemble FILE, trompo.ensemble): the same dispatch with an EnsembleRun in
// place of the sink; simulate() then integrates every member with trompo::integrate_ensemble
// (include/trompo/drivers/ensemble.hpp) and keeps each member's final state; with the control
// flags every member is a closed loop of its own (trompo::integrate_sampled_ensemble).
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
#include <charconv>
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
#include "trompo/drivers/ensemble.hpp"
#include "trompo/drivers/integrate.hpp"
#include "trompo/drivers/sampled.hpp"
#include "trompo/model/cases.hpp"
#include "trompo/schemes/registry.hpp"
#include "trompo/steppers/composition.hpp"

namespace trompo_simulate {

using trompo::invalid_input;
using V3 = Eigen::Vector3d;
using M3 = Eigen::Matrix3d;

/// exp(r̂) of a rotation vector given as input. Throws invalid_input naming `field` when its
/// length overflows (|r|² not finite, |r| ≳ 1e154): a turn that large has no meaningful
/// attitude, and SO3::exp gives a NaN quaternion there.
inline trompo::SO3d attitude_of(const V3& r, const std::string& field) {
  if (!std::isfinite(r.squaredNorm()))
    throw invalid_input(field + ": the rotation vector's length overflows (no attitude exp(R^)); give it modulo 2*pi");
  return trompo::SO3d::exp(r);
}

/// The names --scheme takes: every registered scheme, and the closed forms ("exact").
inline std::string scheme_names() {
  std::string names;
  trompo::RegisteredSchemes::for_each([&](auto entry) { names += std::string(decltype(entry)::type::name) + "|"; });
  return names + "exact";
}

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
  std::optional<double> max_angle;             ///< --max-step-angle (rad): steps that follow the rate [W16]
  /// --controller code: a controller given as code, not as a flag (the Python module's
  /// trompo.control with a callable); the CLI has none to give, and refuses it.
  std::function<trompo::Command<double>(const trompo::Sample<double>&)> code;
  /// mrp-pd's target as a matrix (the Python module's trompo.MrpPd(target=...)), in place
  /// of --target-rotation's rotation vector: no round trip through the logarithm.
  std::optional<M3> target_matrix;
  /// Whether the run is a control run (one scene type for all of them, simulate_core.cpp).
  bool on() const {
    return !wheels_file.empty() || !controller.empty() || period || target || orbit_radius || inclination_deg || max_dipole ||
           max_angle;
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
  bool hold_third_integral = false;    ///< --hold-third-integral (theory [A9])
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

// ---- torque laws given as code (no flag: the Python module's trompo.TorqueLaw) ----
/// A torque law τ(t, Λ, Ω) given as code, in body or space axes (docs/python.md, "A torque
/// law of your own"). Empty: no torque. Its Jacobians (∂τ/∂w for the right perturbation
/// Λ exp(ŵ), and ∂τ/∂Ω, in the law's own axes, theory [W8]) come from `jacobians` when given,
/// else by central differences of the law: 12 more calls per Jacobian evaluation.
struct CodeTorque {
  std::function<V3(double, const M3&, const V3&)> torque;           ///< τ(t, Λ, Ω); empty: zero
  std::function<void(double, const M3&, const V3&, M3&, M3&)> jacobians;  ///< (D_w, D_Ω); empty: differences
  /// Whether a law is given.
  bool on() const { return static_cast<bool>(torque); }
};
// ---- end torque laws ----

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
  bool compensated = false;                     ///< --compensated (simo-kappa, simo-collocation)
  // ---- families (docs/families.md) ----
  std::optional<double> rho_inf;            ///< --rho-inf (lie-gen-alpha)
  std::optional<double> chi;                ///< --chi (energy-decaying)
  std::optional<std::string> chi_schedule;  ///< --chi-schedule (energy-decaying)
  ControlFlags control;                     ///< --wheels, --controller, … (control in the loop)
  // ---- torque laws as code (no flag; trompo.TorqueLaw): schemes simo-kappa, simo-collocation, rk4 ----
  CodeTorque body_law;   ///< τ in body axes
  CodeTorque space_law;  ///< τ in space axes
  /// Whether a torque law is given as code (then the scene of code_torque_scene runs).
  bool code_torques() const { return body_law.on() || space_law.on(); }
};

/// The initial attitude: the given rotation matrix (trompo.State), else exp(R^) of --rotation
/// (attitude_of: a vector whose length overflows is refused, naming the flag).
inline trompo::SO3d initial_attitude(const Config& c) {
  return c.rotation_matrix ? trompo::SO3d::from_matrix(*c.rotation_matrix) : attitude_of(c.rotation, "--rotation");
}

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

// ---- adaptive steps: the checks (each flag's own: flags.cpp) ----
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
/// Reads --wheels FILE: the header gx,gy,gz,Js,speed0,max_torque,max_speed, optionally followed
/// by friction (the viscous coefficient c in N m s/rad, [W17]), then one wheel a line (blank
/// lines and '#' lines skipped); limits may be 'inf'. Throws invalid_input naming the file, the
/// line and the field.
inline std::vector<trompo::Wheel<double>> read_wheels(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw invalid_input("--wheels: cannot open '" + path + "': " + std::strerror(errno));
  static const char* const names[8] = {"gx", "gy", "gz", "Js", "speed0", "max_torque", "max_speed", "friction"};
  std::vector<trompo::Wheel<double>> wheels;
  trompo::ReactionWheels<double> check;
  std::string line;
  long line_no = 0;
  std::size_t columns = 0;  // 7, or 8 with friction; 0 before the header
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
    if (columns == 0) {
      bool same = fields.size() == 7 || fields.size() == 8;
      for (std::size_t i = 0; same && i < fields.size(); ++i) same = fields[i] == names[i];
      if (!same)
        throw invalid_input(where + "expected the header gx,gy,gz,Js,speed0,max_torque,max_speed[,friction]");
      columns = fields.size();
      continue;
    }
    if (fields.size() != columns)
      throw invalid_input(where + "expected " + std::to_string(columns) + " fields, got " + std::to_string(fields.size()));
    double v[8] = {0, 0, 0, 0, 0, 0, 0, 0};
    for (std::size_t i = 0; i < columns; ++i) {
      if ((i == 5 || i == 6) && (fields[i] == "inf" || fields[i] == "Inf" || fields[i] == "INF"))
        v[i] = std::numeric_limits<double>::infinity();
      else
        v[i] = parse_number(where + names[i], fields[i]);
    }
    trompo::Wheel<double> w{.axis = V3(v[0], v[1], v[2]), .inertia = v[3], .speed0 = v[4], .max_torque = v[5],
                            .max_speed = v[6], .friction = v[7]};
    try {
      check.add_wheel(w);  // the library's checks, naming the field (axis, Js, friction, …)
    } catch (const invalid_input& e) {
      throw invalid_input(where + e.what());
    }
    wheels.push_back(w);
  }
  if (columns == 0) throw invalid_input("--wheels: " + path + ": no header line");
  if (wheels.empty()) throw invalid_input("--wheels: " + path + ": no wheels (only a header)");
  return wheels;
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
                        "--orbit-inclination", "--max-dipole", "--max-step-angle"})
    if (by.empty() && flags.count(f)) by = f;
  if (!steps_control_scene(c.scheme))
    throw invalid_input("--scheme " + c.scheme + ": cannot carry reaction wheels, so it runs no " + by +
                        " (control runs: " + control_scheme_names() + ")");
  if (c.mgl != 0 || c.have_effects || c.gravity_gradient)
    throw invalid_input(by + ": a control run's scene has wheels, a held torque and magnetorquers only (no --mgl, "
                             "--damping, --torque, --space-torque, --rotor or --gravity-gradient)");
  if (!c.ensemble.empty() && k.controller == "code")
    throw invalid_input("--controller code: not in an ensemble (a controller given as code runs one loop at a time)");
  // --rtol: adaptive steps between the samples, each hold a new run (docs/control.md); a
  // terminal event would end a hold, not the run: refused.
  if (c.adaptive.on) {
    for (const auto& [name, terminal] : c.adaptive.events)
      if (terminal > 0) throw invalid_input("--event " + name + ":terminal: not in a control run (non-terminal events only)");
    for (const trompo::Event<double>& e : c.adaptive.code_events)  // the Python module's, added before this check
      if (e.terminal > 0)
        throw invalid_input("--event " + e.name + ": terminal: not in a control run (non-terminal events only)");
  }
  if (c.processed) throw invalid_input("--composition blanes-casas-murua-13: not with " + by);
  if (!k.controller.empty() && !k.period) throw invalid_input("--controller: needs --control-period");
  if (k.period && k.controller.empty()) throw invalid_input("--control-period: needs --controller");
  if (k.max_angle && k.controller.empty()) throw invalid_input("--max-step-angle: needs --controller");
  if (k.max_angle && c.adaptive.on) throw invalid_input("--max-step-angle: fixed steps only, not with --rtol");
  // [W17] Viscous wheel friction is split around the steps of the sampled driver, fixed or
  // adaptive; adaptive steps estimate the split step by Richardson's rule (the defect estimate
  // and the reversible control judge one scheme step by the rates, not the split step), and
  // their nodes, rows at --t-eval and events see the friction (W17.a-b).
  const bool friction = std::any_of(k.wheels.begin(), k.wheels.end(), [](const auto& w) { return w.friction > 0; });
  if (friction && c.adaptive.on) {
    const char* with = c.adaptive.control == "reversible" ? "--control reversible"
                       : c.adaptive.estimate == "defect"  ? "--estimate defect"
                                                          : nullptr;
    if (with != nullptr)
      throw invalid_input(std::string("--wheels: a wheel has viscous friction, which adaptive steps (--rtol) take in "
                                      "a split step estimated by Richardson's rule: not with ") +
                          with);
  }
  if (friction && k.controller.empty())
    throw invalid_input("--wheels: a wheel has viscous friction, which the sampled driver applies: give --controller "
                        "and --control-period");
  if (k.period && !(*k.period > 0)) throw invalid_input("--control-period: must be > 0, got " + flags.at("--control-period"));
  if (k.period && c.dt && *k.period < std::abs(*c.dt))
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


/// The checks of the adaptive flags (exit 2 with the reason), after parse_flags' own.
inline void check_adaptive(Config& c, const std::map<std::string, std::string>& flags) {
  AdaptiveFlags& a = c.adaptive;
  if (!a.on) {
    for (const char* f : {"--atol", "--control", "--tol-scope", "--estimate", "--substeps", "--t-eval", "--event", "--event-csv",
                          "--hold-third-integral"})
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


// ---- the command line (flags.cpp, on CLI11: one declaration per flag) ----------------------

/// trompo-simulate --help, generated from the flags' declarations.
std::string usage();

/// The flags (name with its "--" → value; a switch's value empty) as a Config, with the
/// CLI's checks and messages: the Python module's way in (python/trompo_module.cpp).
Config parse_flags(const std::map<std::string, std::string>& flags);

/// The command line as a Config, with the same checks and messages; --help or -h prints
/// usage() and exits 0.
Config parse(int argc, char** argv);

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

/// A number as printf's "%.17g" writes it, at p (25 characters at most); returns the end.
/// std::to_chars with a precision is specified to give printf's text (checked on 6·10⁶
/// doubles), at about a quarter of fprintf's cost: the rows of a large ensemble are mostly
/// this text.
inline char* put_number(char* p, double x) { return std::to_chars(p, p + 32, x, std::chars_format::general, 17).ptr; }

/// The columns of kHeader for one state (t, R00…R22, W1…W3, H, mu, pi1…pi3, iterations),
/// comma-separated, at p (at most 19·26 characters); returns the end.
inline char* put_state_columns(char* p, double t, const M3& R, const V3& W, double H, double mu, const V3& pi,
                               long long iterations) {
  p = put_number(p, t);
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) {
      *p++ = ',';
      p = put_number(p, R(i, j));
    }
  for (const double x : {W.x(), W.y(), W.z(), H, mu, pi.x(), pi.y(), pi.z()}) {
    *p++ = ',';
    p = put_number(p, x);
  }
  *p++ = ',';
  return std::to_chars(p, p + 24, iterations).ptr;
}

/// The CLI's sink: kHeader and `%.17g` rows to a FILE, messages to stderr.
class CsvSink final : public RowSink {
 public:
  explicit CsvSink(std::FILE* out) : out_(out) {}
  void header() override { std::fputs(kHeader, out_); }
  void row(double t, const M3& R, const V3& W, double H, double mu, const V3& pi, long iterations) override {
    char line[512];
    char* p = put_state_columns(line, t, R, W, H, mu, pi, iterations);
    *p++ = '\n';
    std::fwrite(line, 1, static_cast<std::size_t>(p - line), out_);
  }
  void wheel_header(int wheels) override {
    std::string h(kHeader, std::strlen(kHeader) - 1);  // without the newline
    for (int i = 1; i <= wheels; ++i) h += ",wheel" + std::to_string(i);
    for (int i = 1; i <= wheels; ++i) h += ",u" + std::to_string(i);
    std::fprintf(out_, "%s\n", h.c_str());
  }
  void wheel_row(double t, const M3& R, const V3& W, double H, double mu, const V3& pi, long iterations,
                 const double* speeds, const double* torques, int wheels) override {
    char line[1024];  // 19 columns and 2 x 8 wheels' at most 26 characters each
    char* p = put_state_columns(line, t, R, W, H, mu, pi, iterations);
    for (const double* column : {speeds, torques})
      for (int i = 0; i < wheels; ++i) {
        *p++ = ',';
        p = put_number(p, column[i]);
      }
    *p++ = '\n';
    std::fwrite(line, 1, static_cast<std::size_t>(p - line), out_);
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

/// An ensemble in place of a RowSink: the members in, their final states out; with --rtol
/// (adaptive members) each member's states at --t-eval and its events too.
struct EnsembleRun {
  explicit EnsembleRun(const EnsembleInput& in) : input(in) {}
  const EnsembleInput& input;
  std::vector<trompo::State<double>> states;                 ///< final (or last good) state of each member
  std::vector<trompo::IntegrationSummary<double>> summaries;  ///< what integrate did for each (fixed steps)
  std::vector<double> energy;                                 ///< H of the final state, on the member's scene
  std::vector<double> momentum_map;                           ///< μ = up·π
  std::vector<V3> spatial_momentum;                           ///< π
  // ---- adaptive members (--rtol) ----
  std::vector<trompo::AdaptiveSummary<double>> adaptive;      ///< what the adaptive driver did for each
  std::vector<std::vector<trompo::State<double>>> at_times;   ///< each member's states at --t-eval
  /// Each member's events: per --event, the states where it occurred.
  std::vector<std::vector<std::vector<trompo::State<double>>>> events;
  // ---- closed-loop members (the control flags) ----
  std::vector<trompo::SampledMember<double>> sampled;         ///< each member's end: wheels, summary
  int wheels = 0;                                             ///< the wheels of every member (columns)
  std::vector<std::string> messages;                          ///< warnings (an rtol raised to its floor)
  /// Called as progress(done, n) after each chunk of members (EnsembleOptions::progress).
  std::function<void(std::size_t, std::size_t)> progress;
  /// Whether member i reached t_end.
  bool ok(std::size_t i) const {
    if (!sampled.empty()) return sampled[i].summary.ok();
    return adaptive.empty() ? summaries[i].ok() : adaptive[i].ok();
  }
  /// Why member i stopped ("ok" when it did not).
  std::string reason(std::size_t i) const {
    if (!sampled.empty()) return sampled[i].summary.reason();
    if (adaptive.empty()) return summaries[i].reason();
    return adaptive[i].ok() ? "ok" : adaptive[i].message();
  }
  /// Newton iterations of member i.
  long long iterations(std::size_t i) const {
    if (!sampled.empty()) return static_cast<long long>(sampled[i].summary.iterations);
    return static_cast<long long>(adaptive.empty() ? summaries[i].iterations : adaptive[i].iterations);
  }
  std::size_t failed() const {
    std::size_t n = 0;
    for (std::size_t i = 0; i < states.size(); ++i) n += !ok(i);
    return n;
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
