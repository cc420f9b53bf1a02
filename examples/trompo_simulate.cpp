// trompo-simulate: the command-line face of the library.
//
//   trompo-simulate --case ht1 --scheme simo-kappa --dt 0.001 --t-end 10 --every 100
//
// Writes one CSV row per output step:
//   t,R00,R01,R02,R10,R11,R12,R20,R21,R22,W1,W2,W3,H,mu,pi1,pi2,pi3,iterations
// Exit status: 0 done; 2 invalid input (one line on stderr, no rows written);
// 3 a step failed (rows up to the last good state written, stderr names t and why).
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
#include <limits>
#include <type_traits>

#if TROMPO_HAVE_EXACT
#include "trompo/exact/free_body.hpp"
#include "trompo/exact/lagrange_top.hpp"
#endif
#include "trompo/trompo.hpp"

namespace {

using trompo::invalid_input;
using V3 = Eigen::Vector3d;
using M3 = Eigen::Matrix3d;

constexpr const char* kUsage =
    "usage: trompo-simulate [options]\n"
    "  --case ht0|ht1|ht2|fb1|fb2   preset from THEORY 7-8 (other flags override it)\n"
    "  --scheme simo-alpha|simo-collocation|simo-kappa|geradin-bauchau|geradin-bauchau-paper|rk4|exact\n"
    "  --alpha A                    simo-alpha only (default 0.5)\n"
    "  --order 2|4|6                symmetric composition of the scheme (default 2: the scheme itself;\n"
    "                               4: triple jump, 6: Kahan-Li)\n"
    "  --composition triple-jump|suzuki-5|kahan-li-9|mclachlan-15|kahan-li-17   a named composition\n"
    "                               (suzuki-5: order 4 in 5 sub-steps, far smaller error than the\n"
    "                               triple jump; mclachlan-15, kahan-li-17: order 8)\n"
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
    "  --rotor H1,H2,H3             internal rotor angular momentum (body axes)\n";

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
  double damping = 0;
  V3 body_torque = V3::Zero();
  V3 space_torque = V3::Zero();
  V3 rotor = V3::Zero();
  bool have_effects = false;  // any of --damping, --torque, --space-torque, --rotor
};

double parse_number(const std::string& flag, const std::string& text) {
  errno = 0;
  char* end = nullptr;
  const double v = std::strtod(text.c_str(), &end);
  if (text.empty() || end != text.c_str() + text.size() || errno == ERANGE)
    throw invalid_input(flag + ": not a number: '" + text + "'");
  if (!std::isfinite(v)) throw invalid_input(flag + ": must be finite, got " + text);
  return v;
}

std::vector<double> parse_list(const std::string& flag, const std::string& text) {
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

V3 parse_vector(const std::string& flag, const std::string& text) {
  const auto v = parse_list(flag, text);
  if (v.size() != 3) throw invalid_input(flag + ": expected 3 comma-separated numbers, got '" + text + "'");
  return V3(v[0], v[1], v[2]);
}

/// Presets (THEORY 7-8). dt defaults: the finest h the theory names for the case.
void apply_case(const std::string& name, Config& c) {
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

Config parse(int argc, char** argv) {
  std::map<std::string, std::string> flags;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--help" || a == "-h") {
      std::fputs(kUsage, stdout);
      std::exit(0);
    }
    if (a.rfind("--", 0) != 0) throw invalid_input("unexpected argument '" + a + "'");
    if (i + 1 >= argc) throw invalid_input(a + ": missing value");
    if (flags.count(a)) throw invalid_input(a + ": given twice");
    flags[a] = argv[++i];
  }
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
    } else if (flag == "--composition") {
      bool known = false;
      for (const auto m : {trompo::Composition::triple_jump, trompo::Composition::suzuki5, trompo::Composition::kahan_li9,
                           trompo::Composition::mclachlan15, trompo::Composition::kahan_li17})
        if (value == trompo::to_string(m)) {
          c.composition = m;
          known = true;
        }
      if (!known)
        throw invalid_input("--composition: must be triple-jump, suzuki-5, kahan-li-9, mclachlan-15 or kahan-li-17, got " + value);
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
    else throw invalid_input("unknown option '" + flag + "' (see --help)");
  }
  if (!c.have_inertia) throw invalid_input("--inertia: required (or give --case)");
  if (!c.dt) throw invalid_input("--dt: required (or give --case)");
  if (!c.t_end) throw invalid_input("--t-end: required (or give --case)");
  if (*c.dt == 0) throw invalid_input("--dt: must be non-zero, got 0");
  if (*c.t_end != 0 && (*c.t_end > 0) != (*c.dt > 0))
    throw invalid_input("--t-end: " + std::to_string(*c.t_end) + " lies behind the start for --dt " +
                        std::to_string(*c.dt));
  if (c.alpha && c.scheme != "simo-alpha") throw invalid_input("--alpha: only with --scheme simo-alpha");
  if (c.composition) {
    c.order = trompo::CompositionCoefficients<double>::of(*c.composition).order;
    if (c.order_flag && *c.order_flag != c.order)
      throw invalid_input("--order: " + std::to_string(*c.order_flag) + " contradicts --composition " +
                          trompo::to_string(*c.composition) + " (order " + std::to_string(c.order) + ")");
  }
  if (c.order != 2 && (c.scheme == "rk4" || c.scheme == "exact"))
    throw invalid_input("--order: " + std::to_string(c.order) + " needs a symmetric implicit scheme, not " + c.scheme);
  if (c.order != 2 && c.scheme == "simo-alpha" && c.alpha && *c.alpha != 0.5)
    throw invalid_input("--order: simo-alpha is symmetric only for alpha = 0.5");
  if (c.alpha && !(*c.alpha >= 0 && *c.alpha <= 1)) throw invalid_input("--alpha: must be in [0, 1], got " + std::to_string(*c.alpha));
  return c;
}

/// Counts the Newton iterations of the steps since the last written row (a recovered
/// interval counts all its sub-steps); forwards to the wrapped stepper.
template <class StepperT>
struct CountingStepper {
  using Scalar = double;
  const StepperT& stepper;
  mutable long iterations = 0;
  trompo::StepReport<double> step(trompo::State<double>& s, double h) const {
    const auto rep = stepper.step(s, h);
    iterations += rep.iterations;
    return rep;
  }
};

const char* const kHeader = "t,R00,R01,R02,R10,R11,R12,R20,R21,R22,W1,W2,W3,H,mu,pi1,pi2,pi3,iterations\n";

/// One CSV row of state s (`%.17g`).
template <class Scene>
void write_row(std::FILE* out, const Scene& scene, const V3& up, const trompo::State<double>& st, long iterations) {
  const M3 R = st.rotation.matrix();
  const V3 pi = scene.spatial_momentum(st);
  std::fprintf(out, "%.17g", st.time);
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) std::fprintf(out, ",%.17g", R(i, j));
  std::fprintf(out, ",%.17g,%.17g,%.17g,%.17g,%.17g,%.17g,%.17g,%.17g,%ld\n", st.omega.x(), st.omega.y(),
               st.omega.z(), scene.energy(st), up.dot(pi), pi.x(), pi.y(), pi.z(), iterations);
}

/// The number of steps of the grid t0 + k·h to t_end (the last one shortened): as integrate().
long step_count(const Config& c) {
  const double ratio = *c.t_end / *c.dt;
  const double eps = std::numeric_limits<double>::epsilon();
  return std::max(1L, static_cast<long>(std::ceil(ratio - 8 * eps * std::max(ratio, 1.0))));
}

/// Runs `stepper` through trompo::integrate (failed steps are retried as sub-steps) and
/// writes the CSV rows.
template <class StepperT>
int run(const StepperT& stepper, const Config& c, trompo::State<double> s, std::FILE* out) {
  const auto& scene = stepper.scene();
  const V3 up = c.up.normalized();  // μ = γ·π about the given up axis, with or without gravity
  std::fputs(kHeader, out);
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
    std::fprintf(stderr, "trompo-simulate: %lld interval(s) recovered by sub-stepping (%lld failed attempts, %lld sub-steps, depth <= %d)\n",
                 static_cast<long long>(sum.recovered), static_cast<long long>(sum.failures),
                 static_cast<long long>(sum.substeps), sum.max_depth);
  if (!sum.ok()) {
    std::fflush(out);
    std::fprintf(stderr, "trompo-simulate: step failed at t = %.17g (h = %.17g), not recovered by sub-stepping: %s\n",
                 s.time, *c.dt, sum.reason());
    return 3;
  }
  return 0;
}

/// The closed form (THEORY §8) on the same grid: the Lagrange top (J diagonal with
/// J11 = J22, centre of mass on body axis 3) or the torque-free body (J diagonal).
int run_exact(const Config& c, const trompo::RigidBody<double>& body, const trompo::State<double>& s0, std::FILE* out) {
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
    std::fputs(kHeader, out);
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
template <class Scheme, class Scene>
int run_scheme(const Config& c, Scheme scheme, const Scene& scene, const trompo::State<double>& s0, std::FILE* out) {
  if constexpr (std::is_same_v<Scheme, trompo::RK4>) {
    return run(trompo::Stepper<Scheme, Scene>(scheme, scene), c, s0, out);
  } else {
    if (c.order == 2) return run(trompo::Stepper<Scheme, Scene>(scheme, scene), c, s0, out);
    return run(trompo::ComposedStepper<Scheme, Scene>(scheme, scene,
                                                      c.composition ? *c.composition : trompo::composition_of_order(c.order)),
               c, s0, out);
  }
}

template <class Scene>
int dispatch_scheme(const Config& c, const Scene& scene, const trompo::State<double>& s0, std::FILE* out) {
  using namespace trompo;
  if (c.scheme == "simo-alpha") return run_scheme(c, SimoAlpha(c.alpha.value_or(0.5)), scene, s0, out);
  if (c.scheme == "simo-collocation") return run_scheme(c, SimoCollocation{}, scene, s0, out);
  if (c.scheme == "simo-kappa") return run_scheme(c, SimoKappa{}, scene, s0, out);
  if (c.scheme == "geradin-bauchau") return run_scheme(c, GeradinBauchau{}, scene, s0, out);
  if (c.scheme == "geradin-bauchau-paper") return run_scheme(c, GeradinBauchauPaper{}, scene, s0, out);
  if (c.scheme == "rk4") return run_scheme(c, RK4{}, scene, s0, out);
  throw invalid_input("--scheme: unknown scheme '" + c.scheme + "'");
}

}  // namespace

int main(int argc, char** argv) {
  using namespace trompo;
  Config c;
  State<double> s0;
  std::FILE* out = stdout;
  try {
    c = parse(argc, argv);
    const RigidBody<double> body =
        c.unphysical_ok ? RigidBody<double>(c.inertia, allow_unphysical_inertia) : RigidBody<double>(c.inertia);
    s0.rotation = SO3d::exp(c.rotation);
    s0.omega = c.omega;
    s0.validate();
    // Validate the scheme name and the gravity parameters before writing anything.
    static const char* const schemes[] = {"simo-alpha",      "simo-collocation",      "simo-kappa",
                                          "geradin-bauchau", "geradin-bauchau-paper", "rk4", "exact"};
    bool known = false;
    for (const char* name : schemes) known = known || c.scheme == name;
    if (!known) throw invalid_input("--scheme: unknown scheme '" + c.scheme + "'");
    const UniformGravity<double> gravity(c.mgl, c.com, c.up);
    // Effects are validated here too, before any row is written.
    const ViscousDamping<double> damping(c.damping);
    const ConstantBodyTorque<double> body_torque(c.body_torque);
    const ConstantSpaceTorque<double> space_torque(c.space_torque);
    const Rotor<double> rotor(c.rotor);
    if (c.scheme == "exact" && c.have_effects)
      throw invalid_input("--scheme exact: no closed form with damping, torques or a rotor");
    if (c.scheme == "exact" && !body.is_diagonal())
      throw invalid_input("--scheme exact: no closed form for a non-diagonal inertia (give principal axes)");
    if (c.scheme == "exact" && c.mgl != 0 &&
        (std::abs(c.inertia(0, 0) - c.inertia(1, 1)) > 1e-12 * c.inertia.cwiseAbs().maxCoeff() ||
         (c.com.normalized() - V3::UnitZ()).norm() > 1e-14))
      throw invalid_input("--scheme exact: no closed form for this top (needs J11 = J22 and --com 0,0,1: a Lagrange top)");
    if (!c.csv.empty()) {
      out = std::fopen(c.csv.c_str(), "w");
      if (!out) throw invalid_input("--csv: cannot open '" + c.csv + "': " + std::strerror(errno));
    }
    int code = 0;
    // Scenes: the library compiles in exactly the effects a scene names. The CLI keeps
    // three: the free body (no torque computed at all), the heavy top, and, when any of
    // --damping/--torque/--space-torque/--rotor is given, a scene with all of them (those
    // not given are zero) to keep the number of compiled variants small.
    if (c.scheme == "exact") code = run_exact(c, body, s0, out);
    else if (c.have_effects)
      code = dispatch_scheme(c,
                             Scene<double, UniformGravity<double>, ViscousDamping<double>, ConstantBodyTorque<double>,
                                   ConstantSpaceTorque<double>, Rotor<double>>(body, gravity, damping, body_torque,
                                                                               space_torque, rotor),
                             s0, out);
    else if (c.mgl == 0) code = dispatch_scheme(c, FreeScene<double>(body), s0, out);
    else code = dispatch_scheme(c, HeavyTop<double>(body, gravity), s0, out);
    if (out != stdout) std::fclose(out);
    return code;
  } catch (const invalid_input& e) {
    std::fprintf(stderr, "trompo-simulate: %s\n", e.what());
    return 2;
  }
}
