// trompo-simulate's command line on CLI11: one declaration per flag, with the parse and the
// check of its value (the messages name the flag: "--dt: not a number: 'x'"), the help
// generated from the declarations, then the checks across flags (check_flags). The CLI
// (parse) and the Python module (parse_flags: a dict of flags) both come here, so that a
// flag declared here is a keyword of trompo.simulate at once. Only tools/ sees CLI11: the
// library (include/trompo) does not depend on it.
#include <CLI/CLI.hpp>

#include <algorithm>
#include <set>

#include "simulate/simulate_core.hpp"

namespace trompo_simulate {
namespace {

using Flags = std::map<std::string, std::string>;

/// The command line: the CLI11 app and, per flag, how its value goes into the Config.
/// CLI11 collects the values; they are read in declaration order after the whole line is
/// parsed (--case first: every other flag overrides its preset), so that an unknown option
/// or a stray argument is named before any value is read.
class CommandLine {
 public:
  explicit CommandLine(Config& c) : app_("Integrates a rigid body's rotation: one CSV row per output step.", "trompo-simulate") {
    app_.allow_extras();  // named by parse_args, in the CLI's words
    app_.get_formatter()->column_width(34);
    declare(c);
  }

  /// --help's text.
  std::string help() const { return app_.help(); }

  /// Without the help flag (the Python module has usage() for it).
  void drop_help() { app_.set_help_flag(); }

  /// Parses `args` (the command line without the program name, in order) into the Config
  /// given to the constructor; returns the flags given (name → value; a switch's value
  /// empty, --event's occurrences joined by ';') for the checks across flags.
  Flags parse_args(std::vector<std::string> args) {
    // A switch given a value ("--energy-projection=0"): CLI11 would read it as a boolean and
    // count the switch as given; refused instead, as the Python module's energy_projection=0.
    for (const std::string& a : args)
      if (const auto eq = a.find('='); a.rfind("--", 0) == 0 && eq != std::string::npos)
        for (const Declared& d : declared_)
          if (d.is_switch && a.compare(0, eq, d.option->get_name()) == 0 && eq == d.option->get_name().size())
            throw invalid_input(a.substr(0, eq) + ": a switch, it takes no value (got '" + a.substr(eq + 1) + "')");
    std::reverse(args.begin(), args.end());  // CLI11 takes the vector last argument first
    try {
      app_.parse(args);
    } catch (const CLI::CallForHelp&) {
      throw;
    } catch (const CLI::ArgumentMismatch& e) {
      // A flag at the end without its value: CLI11 says "--dt: 1 required H missing".
      const std::string what = e.what();
      const auto colon = what.find(':');
      if (what.rfind("--", 0) == 0 && colon != std::string::npos && what.find(" missing") != std::string::npos)
        throw invalid_input(what.substr(0, colon) + ": missing value");
      throw invalid_input(what);
    } catch (const CLI::ParseError& e) {
      throw invalid_input(e.what());
    }
    if (const auto rest = app_.remaining(); !rest.empty()) {
      const std::string& a = rest.front();
      if (a.rfind("--", 0) == 0 && a != "--")
        throw invalid_input("unknown option '" + a.substr(0, a.find('=')) + "' (see --help)");
      throw invalid_input("unexpected argument '" + a + "'");
    }
    Flags given;
    for (const Declared& d : declared_) {
      const std::size_t n = d.option->count();
      if (n == 0) continue;
      const std::string name = d.option->get_name();
      if (d.is_switch) {
        if (n > 1) throw invalid_input(name + ": given twice");
        given[name] = "";
        d.apply("");
        continue;
      }
      const std::vector<std::string> values = d.option->results();
      if (values.size() > 1 && !d.repeatable) throw invalid_input(name + ": given twice");
      std::string joined;
      for (const std::string& v : values) joined += (joined.empty() ? "" : ";") + v;
      given[name] = joined;
      d.apply(joined);
    }
    return given;
  }

 private:
  struct Declared {
    CLI::Option* option;
    std::function<void(const std::string&)> apply;
    bool repeatable;
    bool is_switch;
  };

  /// A flag with a value VALUE, read by `apply` (which checks it and names the flag).
  void value(const std::string& name, const std::string& meta, const std::string& help,
             std::function<void(const std::string&)> apply, bool repeatable = false) {
    CLI::Option* o = app_.add_option(name, help)->type_name(meta)->allow_extra_args(false);
    o->multi_option_policy(CLI::MultiOptionPolicy::TakeAll);
    o->group(group_);
    declared_.push_back({o, std::move(apply), repeatable, false});
  }

  /// A switch (no value).
  void flag(const std::string& name, const std::string& help, std::function<void()> apply) {
    CLI::Option* o = app_.add_flag(name, help);
    o->group(group_);
    declared_.push_back({o, [apply = std::move(apply)](const std::string&) { apply(); }, false, true});
  }

  void declare(Config& c);

  CLI::App app_;
  std::vector<Declared> declared_;
  std::string group_ = "Options";
};

/// The flags, one declaration each: name, what the value looks like, the help line, and
/// how it is read and checked.
void CommandLine::declare(Config& c) {
  // ---- the scene and the run ----
  group_ = "The body and the run";
  value("--case", "ht0|ht1|ht2|fb1|fb2|sat1|sat2",
        "preset from docs/theory.md §7-8 and docs/spacecraft.md (other flags override it)",
        [&c](const std::string& v) { apply_case(v, c); });
  value("--inertia", "J11,J22,J33[,J12,J13,J23]", "body axes, about the fixed point", [&c](const std::string& v) {
    const auto j = parse_list("--inertia", v);
    if (j.size() != 3 && j.size() != 6)
      throw invalid_input("--inertia: expected J11,J22,J33 or J11,J22,J33,J12,J13,J23, got '" + v + "'");
    c.inertia = M3::Zero();
    c.inertia.diagonal() << j[0], j[1], j[2];
    if (j.size() == 6) {
      c.inertia(0, 1) = c.inertia(1, 0) = j[3];
      c.inertia(0, 2) = c.inertia(2, 0) = j[4];
      c.inertia(1, 2) = c.inertia(2, 1) = j[5];
    }
    c.have_inertia = true;
    c.unphysical_ok = false;
  });
  value("--mgl", "W", "M*g*l (0 = no gravity)", [&c](const std::string& v) { c.mgl = parse_number("--mgl", v); });
  value("--com", "E1,E2,E3", "body direction to the centre of mass (normalised)",
        [&c](const std::string& v) { c.com = parse_vector("--com", v); });
  value("--up", "G1,G2,G3", "spatial up (normalised)", [&c](const std::string& v) { c.up = parse_vector("--up", v); });
  value("--rotation", "R1,R2,R3", "initial rotation vector, Lambda0 = exp(R^)",
        [&c](const std::string& v) { c.rotation = parse_vector("--rotation", v); });
  value("--omega", "W1,W2,W3", "initial body angular velocity",
        [&c](const std::string& v) { c.omega = parse_vector("--omega", v); });
  value("--dt", "H", "the step (with --rtol: the first step, optional)",
        [&c](const std::string& v) { c.dt = parse_number("--dt", v); });
  value("--t-end", "T", "the end of the run", [&c](const std::string& v) { c.t_end = parse_number("--t-end", v); });
  value("--every", "K", "write every K-th step (default 1); the last step is always written", [&c](const std::string& v) {
    const double k = parse_number("--every", v);
    if (!(k >= 1) || k != std::floor(k) || k > 1e15) throw invalid_input("--every: must be a positive integer, got " + v);
    c.every = static_cast<long>(k);
  });
  value("--csv", "FILE", "default: standard output", [&c](const std::string& v) { c.csv = v; });
  value("--progress-after", "S",
        "stderr a terminal: progress lines after S seconds of a fixed-step run, then once a second (default 3)",
        [&c](const std::string& v) {
          const double a = parse_number("--progress-after", v);
          if (!(a >= 0) || !std::isfinite(a))
            throw invalid_input("--progress-after: must be a finite number of seconds >= 0, got " + v);
          c.progress_after = a;
        });

  // ---- the scheme ----
  group_ = "The scheme";
  value("--scheme", scheme_names(), "(default simo-kappa; with --rtol and no --order: picked, docs/adaptive.md)",
        [&c](const std::string& v) { c.scheme = v; });
  value("--alpha", "A", "simo-alpha only (default 0.5)", [&c](const std::string& v) { c.alpha = parse_number("--alpha", v); });
  value("--order", "2|4|6",
        "symmetric composition of the scheme (default 2: the scheme itself; 4: triple jump, 6: Kahan-Li)",
        [&c](const std::string& v) {
          const double k = parse_number("--order", v);
          if (k != 2 && k != 4 && k != 6) throw invalid_input("--order: must be 2, 4 or 6, got " + v);
          c.order = static_cast<int>(k);
          c.order_flag = c.order;
        });
  value("--composition", "NAME",
        "triple-jump|suzuki-5|kahan-li-9|mclachlan-15|kahan-li-17: a named composition (suzuki-5: order 4\n"
        "in 5 sub-steps, far smaller error than the triple jump; mclachlan-15, kahan-li-17: order 8);\n"
        "blanes-casas-murua-13: processed order 6, a 13-step kernel between a pre- and a post-processor\n"
        "(12 steps each), every row post-processed; with --scheme splitting (docs/splitting.md):\n"
        "strang|chin-4a|chin-triple-jump|suzuki-5|kahan-li-9|saba2c|saba3c|saba4c|sbab2c|sbab3c\n"
        "(suzuki-5, kahan-li-9: compositions of Strang; sabaNc, sbabNc: Laskar-Robutel with corrector,\n"
        "small torques; with --wheels without it, order 2 [W18]); default by --order: chin-4a / chin-triple-jump where they apply, else\n"
        "suzuki-5 / kahan-li-9",
        [&c](const std::string& v) {
          c.composition_name = v;
          bool known = false;  // the splitting's own methods (strang, chin-4a, …, saba4c, sbab3c)
          for (const auto m : trompo::all_splitting_methods)
            if (v == trompo::to_string(m) && v != "suzuki-5" && v != "kahan-li-9") known = true;
          for (const auto m : {trompo::Composition::triple_jump, trompo::Composition::suzuki5, trompo::Composition::kahan_li9,
                               trompo::Composition::mclachlan15, trompo::Composition::kahan_li17})
            if (v == trompo::to_string(m)) {
              c.composition = m;
              known = true;
            }
          if (v == "blanes-casas-murua-13") c.processed = known = true;
          if (!known)
            throw invalid_input(
                "--composition: must be triple-jump, suzuki-5, kahan-li-9, mclachlan-15, kahan-li-17 or "
                "blanes-casas-murua-13 (with --scheme splitting: strang, chin-4a, chin-triple-jump, suzuki-5, kahan-li-9, "
                "saba2c, saba3c, saba4c, sbab2c or sbab3c), got " + v);
        });
  flag("--energy-projection", "splitting: project H back after each step (keeps pi)",
       [&c] { c.energy_projection = true; });
  flag("--compensated",
       "simo-kappa, simo-collocation, lgvi: carry the state's rounding residue, H and mu (the lgvi: pi and mu) "
       "to a few eps over any number of steps (3-16 % a step; docs/theory.md section 18)",
       [&c] { c.compensated = true; });
  // ---- families (docs/families.md) ----
  value("--rho-inf", "R", "lie-gen-alpha only: spectral radius at infinity in [0, 1] (default 0.8)",
        [&c](const std::string& v) { c.rho_inf = parse_number("--rho-inf", v); });
  value("--chi", "X", "energy-decaying only: dissipation in [0, 1] (default 0: energy-momentum)",
        [&c](const std::string& v) { c.chi = parse_number("--chi", v); });
  value("--chi-schedule", "constant|sensor", "energy-decaying only (default constant)",
        [&c](const std::string& v) { c.chi_schedule = v; });

  // ---- effects ----
  group_ = "Effects";
  value("--damping", "C", "viscous damping torque -C*Omega (C >= 0)", [&c](const std::string& v) {
    c.damping = parse_number("--damping", v);
    c.have_effects = true;
  });
  flag("--allow-negative-damping", "accept C < 0 (the torque then feeds energy in)",
       [&c] { c.allow_negative_damping = true; });
  value("--torque", "T1,T2,T3", "constant body-fixed torque", [&c](const std::string& v) {
    c.body_torque = parse_vector("--torque", v);
    c.have_effects = true;
  });
  value("--space-torque", "S1,S2,S3", "constant space-fixed torque", [&c](const std::string& v) {
    c.space_torque = parse_vector("--space-torque", v);
    c.have_effects = true;
  });
  value("--rotor", "H1,H2,H3", "internal rotor angular momentum (body axes)", [&c](const std::string& v) {
    c.rotor = parse_vector("--rotor", v);
    c.have_effects = true;
  });

  // ---- satellite (docs/spacecraft.md) ----
  group_ = "A satellite (docs/spacecraft.md)";
  value("--gravity-gradient", "N",
        "gravity gradient of a circular orbit of rate N rad/s; the H column is then the Jacobi integral",
        [&c](const std::string& v) { c.gravity_gradient = parse_number("--gravity-gradient", v); });
  value("--orbit-normal", "O1,O2,O3", "with --gravity-gradient: the orbit normal (default 0,0,1)",
        [&c](const std::string& v) { c.orbit_normal = parse_vector("--orbit-normal", v); });
  value("--radial", "R1,R2,R3",
        "with --gravity-gradient: the radial direction at t = 0, orthogonal to the orbit normal (default 1,0,0)",
        [&c](const std::string& v) { c.radial = parse_vector("--radial", v); });

  // ---- ensembles (docs/python.md) ----
  group_ = "Ensembles (docs/python.md)";
  value("--ensemble", "FILE",
        "integrate every initial state of FILE (CSV with header\n"
        "rotation1,rotation2,rotation3,omega1,omega2,omega3[,mgl][,J11,J22,J33[,J12,J13,J23]])\n"
        "across cores; writes each member's final state",
        [&c](const std::string& v) { c.ensemble = v; });
  value("--threads", "N", "with --ensemble: worker threads (default 0: every core)", [&c](const std::string& v) {
    const double k = parse_number("--threads", v);
    if (!(k >= 0) || k != std::floor(k) || k > 4096) throw invalid_input("--threads: must be an integer in [0, 4096], got " + v);
    c.threads = static_cast<unsigned>(k);
  });

  // ---- adaptive steps (docs/adaptive.md) ----
  group_ = "Adaptive steps (docs/adaptive.md)";
  AdaptiveFlags& a = c.adaptive;
  value("--rtol", "R",
        "adaptive steps to the relative tolerance R (below 100 eps: raised to it); --dt, optional,\n"
        "is then the first step; without --scheme, --order and --composition the method is picked\n"
        "for the scene",
        [&a](const std::string& v) {
          a.on = true;
          a.rtol = parse_number("--rtol", v);
        });
  value("--atol", "A", "absolute tolerance (default 1e-6)", [&a](const std::string& v) { a.atol = parse_number("--atol", v); });
  value("--control", "tolerance|reversible",
        "error estimate + PI control (default), or Hairer-Soderlind's time-reversible step density\n"
        "(conservative scenes, long runs)",
        [&a](const std::string& v) { a.control = v; });
  value("--tol-scope", "span|time",
        "the tolerances bound the end error of the run (default), or the error per unit time (the end\n"
        "error then grows like tol*t)",
        [&a](const std::string& v) { a.tol_scope = v; });
  value("--estimate", "automatic|defect|richardson|doubling",
        "tolerance mode's error estimate (default automatic: Richardson's for the splitting, else the\n"
        "interpolant's defect up to order 6 and step doubling above)",
        [&a](const std::string& v) { a.estimate = v; });
  flag("--hold-third-integral",
       "Lagrange top (symmetric body, centre of mass on its axis), simo schemes: hold Omega3 with H and\n"
       "mu against drift (docs/theory.md [A9]; the nutation phase of long runs)",
       [&a] { a.hold_third_integral = true; });
  value("--substeps", "M", "Richardson's estimate: steps per attempt, 2..16 (default 8)", [&a](const std::string& v) {
    const double m = parse_number("--substeps", v);
    constexpr int most = trompo::AdaptiveOptions<double>::max_substeps;
    if (!(m >= 2 && m <= most && m == std::floor(m)))
      throw invalid_input("--substeps: must be an integer in [2, " + std::to_string(most) + "], got " + v);
    a.substeps = static_cast<int>(m);
  });
  value("--t-eval", "T1,T2,...|@FILE", "rows at exactly these times (dense output), and only these",
        [&a](const std::string& v) {
          if (!v.empty() && v[0] == '@') {  // @FILE: one time a line (blank lines skipped)
            std::ifstream in(v.substr(1));
            if (!in) throw invalid_input("--t-eval: cannot open '" + v.substr(1) + "'");
            std::string line;
            while (std::getline(in, line)) {
              if (line.find_first_not_of(" \t\r") == std::string::npos) continue;
              a.t_eval.push_back(parse_number("--t-eval", line));
            }
            if (a.t_eval.empty()) throw invalid_input("--t-eval: no time in '" + v.substr(1) + "'");
          } else {
            a.t_eval = parse_list("--t-eval", v);
          }
        });
  value(
      "--event", "NAME[:terminal[:N]]", "nutation-max|nutation-min|axis-crossing|flip (repeatable)",
      [&a](const std::string& v) {
        std::stringstream list(v);  // the occurrences, joined by ';'
        std::string item;
        while (std::getline(list, item, ';')) {
          // NAME, NAME:terminal (the first occurrence ends the run) or NAME:terminal:N (the N-th)
          const auto colon = item.find(':');
          const std::string name = item.substr(0, colon);
          int terminal = 0;
          if (colon != std::string::npos) {
            const std::string rest = item.substr(colon + 1);
            if (rest == "terminal") {
              terminal = 1;
            } else if (rest.rfind("terminal:", 0) == 0) {
              const double n = parse_number("--event", rest.substr(9));
              if (!(n >= 1 && n <= 1e9) || n != std::floor(n))
                throw invalid_input("--event " + item + ": the count must be a positive integer");
              terminal = static_cast<int>(n);
            } else {
              throw invalid_input("--event " + item + ": expected NAME, NAME:terminal or NAME:terminal:N");
            }
          }
          a.events.emplace_back(name, terminal);
        }
      },
      /*repeatable=*/true);
  value("--event-csv", "FILE", "one row per event: event, then the usual columns",
        [&a](const std::string& v) { a.event_csv = v; });

  // ---- control in the loop (docs/control.md) ----
  group_ = "Control in the loop (docs/control.md)";
  ControlFlags& k = c.control;
  value("--wheels", "FILE",
        "reaction wheels: CSV with header gx,gy,gz,Js,speed0,max_torque,max_speed[,friction] (axis in\n"
        "body axes, axial inertia, initial speed relative to the body in rad/s, limits in N m and rad/s,\n"
        "'inf' for none, viscous friction in N m s/rad, which --rtol takes without --estimate\n"
        "defect and --control reversible); --inertia is then the whole\n"
        "spacecraft's; adds columns wheel1..N (speeds) and\n"
        "u1..N (motor torques held from the row on). A control run takes fixed steps of --dt between\n"
        "the samples (or adaptive steps over each hold with --rtol), with a scheme that carries\n"
        "wheels: simo-kappa, simo-collocation, simo-alpha, lgvi, rk4 and their compositions, the splitting",
        [&k](const std::string& v) {
          k.wheels_file = v;
          k.wheels = read_wheels(v);
        });
  value("--controller", "mrp-pd:K,P|bdot:k",
        "sampled every --control-period T seconds (zero-order hold): mrp-pd: L = -K sigma - P Omega\n"
        "to --target-rotation, on the wheels (axes spanning 3-D) or, without --wheels, as a body\n"
        "torque; bdot: m = -k dB/dt on magnetorquers (needs --orbit-radius)",
        [&k](const std::string& v) {
          const auto colon = v.find(':');
          const std::string name = v.substr(0, colon);
          const std::string args = colon == std::string::npos ? std::string() : v.substr(colon + 1);
          if (name == "mrp-pd") {
            const auto g = colon == std::string::npos ? std::vector<double>{} : parse_list("--controller mrp-pd", args);
            if (g.size() != 2) throw invalid_input("--controller mrp-pd: expected mrp-pd:K,P, got '" + v + "'");
            if (!(g[0] >= 0 && g[1] >= 0)) throw invalid_input("--controller mrp-pd: K and P must be >= 0, got '" + v + "'");
            k.K = g[0];
            k.P = g[1];
          } else if (name == "bdot") {
            if (colon == std::string::npos) throw invalid_input("--controller bdot: expected bdot:k, got '" + v + "'");
            k.k = parse_number("--controller bdot: k", args);
            if (!(k.k >= 0)) throw invalid_input("--controller bdot: k must be >= 0, got '" + v + "'");
          } else if (name == "code" && colon == std::string::npos) {
            // A controller given as code (ControlFlags::code): the Python module's; without it
            // make_controller refuses the run.
          } else {
            throw invalid_input("--controller: unknown controller '" + name + "' (mrp-pd:K,P or bdot:k)");
          }
          k.controller = name;
        });
  value("--control-period", "T", "the sample period (> 0, at least |--dt|); required with --controller",
        [&k](const std::string& v) { k.period = parse_number("--control-period", v); });
  value("--max-step-angle", "RAD",
        "with --controller and --dt: each hold split into the fewest equal steps, none longer than\n"
        "--dt, that turn the body by at most RAD at the sample's rate (a tumbling body gets more steps\n"
        "a sample, a slow one one step; docs/control.md)",
        [&k](const std::string& v) {
          k.max_angle = parse_number("--max-step-angle", v);
          if (!(*k.max_angle > 0)) throw invalid_input("--max-step-angle: must be > 0 (rad), got " + v);
        });
  value("--target-rotation", "R1,R2,R3", "mrp-pd's inertial target as a rotation vector, as --rotation (default 0)",
        [&k](const std::string& v) { k.target = parse_vector("--target-rotation", v); });
  value("--orbit-radius", "M",
        "magnetorquers in the Earth's field (centred dipole, IGRF-13 2020.0) along a circular orbit of\n"
        "radius M metres",
        [&k](const std::string& v) {
          k.orbit_radius = parse_number("--orbit-radius", v);
          if (!(*k.orbit_radius > 0)) throw invalid_input("--orbit-radius: must be > 0 (m), got " + v);
        });
  value("--orbit-inclination", "DEG", "with --orbit-radius: inclination in degrees (default 0)",
        [&k](const std::string& v) { k.inclination_deg = parse_number("--orbit-inclination", v); });
  value("--max-dipole", "X", "with --orbit-radius: dipole limit per axis, A m^2 (default none)", [&k](const std::string& v) {
    k.max_dipole = parse_number("--max-dipole", v);
    if (!(*k.max_dipole > 0)) throw invalid_input("--max-dipole: must be > 0 (A m^2), got " + v);
  });
}

/// The checks across flags, after each flag's own (exit 2 naming the flag).
void check_flags(Config& c, const Flags& flags) {
  // --compensated asks for a residue-carrying scheme: no pick then (the default scheme stays).
  if (c.adaptive.on && !flags.count("--scheme") && !flags.count("--order") && !flags.count("--composition") &&
      !flags.count("--compensated") && !c.control.on() && c.ensemble.empty())  // (both refuse --rtol, below)
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
  if (c.compensated && c.scheme != "simo-kappa" && c.scheme != "simo-collocation" && c.scheme != "lgvi")
    throw invalid_input("--compensated: only with --scheme simo-kappa, simo-collocation or lgvi (the schemes whose "
                        "memory carries the state's residue), got " + c.scheme);
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
      // (a control run's scene carries wheels: order_with_wheels, [W18])
      for (const auto m : trompo::all_splitting_methods)
        if (*c.composition_name == trompo::to_string(m)) k = c.control.on() ? trompo::order_with_wheels(m) : trompo::order_of(m);
      if (c.order_flag && *c.order_flag != k)
        throw invalid_input("--order: " + std::to_string(*c.order_flag) + " contradicts --composition " +
                            *c.composition_name + " (order " + std::to_string(k) + ")");
      c.order = k;
    }
    if (!c.ensemble.empty())
      for (const char* f : {"--rotation", "--omega", "--every"})
        if (flags.count(f)) throw invalid_input(std::string("--ensemble: the initial states come from the file; drop ") + f);
    check_control(c, flags);   // control in the loop: its flags (the splitting carries wheels, [W14])
    check_adaptive(c, flags);  // adaptive steps (before this return, the splitting skipped them)
    return;
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
}

}  // namespace

std::string usage() {
  Config c;
  return CommandLine(c).help();
}

Config parse_flags(const std::map<std::string, std::string>& flags) {
  // The dict as a command line ("--name=value": a value may start with '-'), CLI11 parsing
  // it as it parses the CLI's.
  // A switch is given with an empty value; with another, parse_args refuses it. --event:
  // its occurrences joined by ';', as parse_args joins the CLI's.
  static const std::set<std::string> switches = {"--energy-projection", "--allow-negative-damping", "--compensated",
                                                 "--hold-third-integral"};
  std::vector<std::string> args;
  for (const auto& [flag, value] : flags) args.push_back(switches.count(flag) && value.empty() ? flag : flag + "=" + value);
  Config c;
  CommandLine line(c);
  line.drop_help();
  const Flags given = line.parse_args(std::move(args));
  check_flags(c, given);
  return c;
}

Config parse(int argc, char** argv) {
  Config c;
  CommandLine line(c);
  Flags given;
  try {
    given = line.parse_args(std::vector<std::string>(argv + 1, argv + argc));
  } catch (const CLI::CallForHelp&) {
    std::fputs(line.help().c_str(), stdout);
    std::exit(0);
  }
  check_flags(c, given);
  return c;
}

}  // namespace trompo_simulate
