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

#if TROMPO_HAVE_EXACT
#include "trompo/exact/free_body.hpp"
#include "trompo/exact/lagrange_top.hpp"
#endif
#include "trompo/drivers/ensemble.hpp"
#include "trompo/trompo.hpp"

namespace trompo_simulate {

using trompo::invalid_input;
using V3 = Eigen::Vector3d;
using M3 = Eigen::Matrix3d;

constexpr const char* kUsage =
    "usage: trompo-simulate [options]\n"
    "  --case ht0|ht1|ht2|fb1|fb2   preset from docs/theory.md §7-8 (other flags override it)\n"
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
    "  --damping C                  viscous damping torque -C*Omega\n"
    "  --torque T1,T2,T3            constant body-fixed torque\n"
    "  --space-torque S1,S2,S3      constant space-fixed torque\n"
    "  --rotor H1,H2,H3             internal rotor angular momentum (body axes)\n"
    "  --ensemble FILE              integrate every initial state of FILE (CSV with header\n"
    "                               rotation1,rotation2,rotation3,omega1,omega2,omega3[,mgl][,J11,J22,J33[,J12,J13,J23]])\n"
    "                               across cores; writes each member's final state (docs/python.md)\n"
    "  --threads N                  with --ensemble: worker threads (default 0: every core)\n";

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

/// Whether `name` is a --scheme the CLI runs.
inline bool known_scheme(const std::string& name) {
  static const char* const schemes[] = {"simo-alpha",      "simo-collocation",      "simo-kappa",
                                        "geradin-bauchau", "geradin-bauchau-paper", "rk4", "exact",
                                        "splitting",       "lie-gen-alpha",         "constrained-trapezoid",
                                        "energy-decaying"};
  return std::any_of(std::begin(schemes), std::end(schemes), [&](const char* s) { return name == s; });
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
  return c;
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

/// Runs `stepper` through trompo::integrate (failed steps are retried as sub-steps) and
/// writes the CSV rows.
template <class StepperT>
int run(const StepperT& stepper, const Config& c, trompo::State<double> s, RowSink& out) {
  const auto& scene = stepper.scene();
  const V3 up = c.up.normalized();  // μ = γ·π about the given up axis, with or without gravity
  out.header();
  const long n = step_count(c);
  const CountingStepper<StepperT> counting{stepper};
  long k = -1;  // the observer's first call is at t0
  auto observer = [&](const trompo::State<double>& st) {
    ++k;
    if (k == 0 || k % c.every == 0 || k == n) {
      write_row(out, scene, up, st, counting.iterations);
      counting.iterations = 0;
    }
  };
  const auto sum = trompo::integrate(counting, s, *c.t_end, *c.dt, observer);
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
    if (c.scheme == "energy-decaying") {
      const ChiSchedule schedule = c.chi_schedule.value_or("constant") == "sensor" ? ChiSchedule::sensor : ChiSchedule::constant;
      return run(Stepper<EnergyDecaying, Scene>(EnergyDecaying(c.chi.value_or(0.0), schedule), scene), c, s0, out);
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
  if (c.have_effects)
    return f(Scene<double, UniformGravity<double>, ViscousDamping<double>, ConstantBodyTorque<double>,
                   ConstantSpaceTorque<double>, Rotor<double>>(body, gravity, ViscousDamping<double>(c.damping),
                                                               ConstantBodyTorque<double>(c.body_torque),
                                                               ConstantSpaceTorque<double>(c.space_torque),
                                                               Rotor<double>(c.rotor)));
  if (mgl == 0 && !heavy) return f(FreeScene<double>(body));
  return f(HeavyTop<double>(body, gravity));
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
