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
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include <algorithm>
#include <iterator>
#include <type_traits>

#include "trompo/drivers/integrate.hpp"
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
    "  --composition strang|chin-4a|chin-triple-jump|suzuki-5|kahan-li-9   with --scheme splitting\n"
    "                               (suzuki-5, kahan-li-9: compositions of Strang); default by --order:\n"
    "                               chin-4a / chin-triple-jump where they apply, else suzuki-5 / kahan-li-9\n"
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
    "  --damping C                  viscous damping torque -C*Omega\n"
    "  --torque T1,T2,T3            constant body-fixed torque\n"
    "  --space-torque S1,S2,S3      constant space-fixed torque\n"
    "  --rotor H1,H2,H3             internal rotor angular momentum (body axes)\n"
    "  --ensemble FILE              integrate every initial state of FILE (CSV with header\n"
    "                               rotation1,rotation2,rotation3,omega1,omega2,omega3[,mgl][,J11,J22,J33[,J12,J13,J23]])\n"
    "                               across cores; writes each member's final state (docs/python.md)\n"
    "  --threads N                  with --ensemble: worker threads (default 0: every core)\n";

/// trompo-simulate --help.
inline std::string usage() {
  return "usage: trompo-simulate [options]\n"
         "  --case ht0|ht1|ht2|fb1|fb2   preset from docs/theory.md §7-8 (other flags override it)\n"
         "  --scheme " + scheme_names() + "\n" + kUsageFlags;
}

struct Config {
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
  V3 body_torque = V3::Zero();
  V3 space_torque = V3::Zero();
  V3 rotor = V3::Zero();
  bool have_effects = false;  // any of --damping, --torque, --space-torque, --rotor
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
    if constexpr (!std::decay_t<decltype(preset.scene)>::is_free) {
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
  else throw invalid_input("--case: unknown case '" + name + "' (ht0, ht1, ht2, fb1, fb2)");
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
      bool known = value == "strang" || value == "chin-4a" || value == "chin-triple-jump";  // splitting only
      for (const auto m : {trompo::Composition::triple_jump, trompo::Composition::suzuki5, trompo::Composition::kahan_li9,
                           trompo::Composition::mclachlan15, trompo::Composition::kahan_li17})
        if (value == trompo::to_string(m)) {
          c.composition = m;
          known = true;
        }
      if (value == "blanes-casas-murua-13") c.processed = known = true;
      if (!known)
        throw invalid_input("--composition: must be triple-jump, suzuki-5, kahan-li-9, mclachlan-15, kahan-li-17 or blanes-casas-murua-13 (with --scheme splitting: strang, "
                            "chin-4a, chin-triple-jump, suzuki-5 or kahan-li-9), got " + value);
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
  if (c.alpha && c.scheme != "simo-alpha") throw invalid_input("--alpha: only with --scheme simo-alpha");
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
                              ": not a splitting method (strang, chin-4a, chin-triple-jump, suzuki-5, kahan-li-9)");
      const int k = *c.composition_name == "strang" ? 2 : *c.composition_name == "chin-4a" || *c.composition_name == "suzuki-5" ? 4 : 6;
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
  if (!c.ensemble.empty())
    for (const char* f : {"--rotation", "--omega", "--every"})
      if (flags.count(f)) throw invalid_input(std::string("--ensemble: the initial states come from the file; drop ") + f);
  return c;
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
    if (a == "--energy-projection") {  // splitting: the one flag without a value
      if (flags.count(a)) throw invalid_input(a + ": given twice");
      flags[a] = "";
      continue;
    }
    if (i + 1 >= argc) throw invalid_input(a + ": missing value");
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
  /// Rows so far are final (before a failure message).
  virtual void flush() {}
  /// A line for the user (the CLI's stderr), without the program name and newline.
  virtual void message(const std::string& text) = 0;
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
