// trompo._trompo: the C++ half of the Python module `trompo` (python/trompo/__init__.py is
// the other half). It runs trompo-simulate's own logic (tools/simulate/simulate_core.hpp):
// the same flag parser with the same messages, the same checks, the same dispatch; rows go
// to NumPy arrays instead of a CSV file, so they are bit-identical to the CLI's. The GIL is
// released while C++ integrates.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <cstdint>
#include <limits>
#include <map>
#include <string>
#include <vector>

#include "simulate/simulate_core.hpp"

namespace py = pybind11;
using namespace trompo_simulate;

namespace {

/// A C-contiguous array of doubles (converted from any array-like).
using Array = py::array_t<double, py::array::c_style | py::array::forcecast>;

/// Rows as columns of doubles, turned into NumPy arrays without a copy at the end.
class ArraySink : public RowSink {
 public:
  std::vector<double> t, R, W, H, mu, pi;
  std::vector<std::int64_t> iterations;
  std::vector<std::string> messages;

  void reserve(std::size_t rows) {
    t.reserve(rows);
    R.reserve(9 * rows);
    W.reserve(3 * rows);
    H.reserve(rows);
    mu.reserve(rows);
    pi.reserve(3 * rows);
    iterations.reserve(rows);
  }
  void header() override {}
  void row(double t_, const M3& R_, const V3& W_, double H_, double mu_, const V3& pi_, long iterations_) override {
    t.push_back(t_);
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) R.push_back(R_(i, j));  // row-major, as R00,R01,… in the CSV
    for (int i = 0; i < 3; ++i) W.push_back(W_(i));
    H.push_back(H_);
    mu.push_back(mu_);
    for (int i = 0; i < 3; ++i) pi.push_back(pi_(i));
    iterations.push_back(iterations_);
  }
  void message(const std::string& text) override { messages.push_back(text); }
};

/// A NumPy array owning the vector's buffer (moved, not copied).
template <class T>
py::array_t<T> to_array(std::vector<T>&& v, std::vector<py::ssize_t> shape) {
  auto* owned = new std::vector<T>(std::move(v));
  py::capsule owner(owned, [](void* p) { delete static_cast<std::vector<T>*>(p); });
  return py::array_t<T>(shape, owned->data(), owner);
}

py::dict rows_of(ArraySink& s) {
  const auto n = static_cast<py::ssize_t>(s.t.size());
  py::dict d;
  d["t"] = to_array(std::move(s.t), {n});
  d["R"] = to_array(std::move(s.R), {n, 3, 3});
  d["W"] = to_array(std::move(s.W), {n, 3});
  d["H"] = to_array(std::move(s.H), {n});
  d["mu"] = to_array(std::move(s.mu), {n});
  d["pi"] = to_array(std::move(s.pi), {n, 3});
  d["iterations"] = to_array(std::move(s.iterations), {n});
  return d;
}

/// The flags parsed (not yet validated); invalid_input as ValueError.
Config parse_config(const std::map<std::string, std::string>& flags) {
  try {
    return parse_flags(flags);
  } catch (const invalid_input& e) {
    throw py::value_error(e.what());
  }
}

Config config_of(const std::map<std::string, std::string>& flags) {
  Config c = parse_config(flags);
  try {
    validate(c);
  } catch (const invalid_input& e) {
    throw py::value_error(e.what());
  }
  return c;
}

/// An event function of Python, g(t, y) with y = (Λ row-major, Ω) as solve_ivp's columns,
/// as the engine's g(t, Λ, Ω). The engine runs without the GIL: each call takes it. The
/// callable is held by pointer (the caller's list keeps it alive for the run), so that
/// copies of the std::function touch no Python reference count without the GIL. An
/// exception raised in g ends the run and is raised again by simulate_flags.
trompo::Event<double> python_event(const py::handle& item) {
  const py::tuple t = py::reinterpret_borrow<py::tuple>(item);
  if (t.size() != 4) throw py::value_error("events: expected (name, callable, direction, terminal) tuples");
  trompo::Event<double> e;
  e.name = t[0].cast<std::string>();
  PyObject* fn = t[1].ptr();
  e.direction = t[2].cast<int>();
  e.terminal = t[3].cast<int>();
  if (e.direction < -1 || e.direction > 1) throw py::value_error("events: direction must be -1, 0 or 1");
  if (e.terminal < 0) throw py::value_error("events: terminal must be a bool or a count >= 0");
  const std::string name = e.name;
  e.g = [fn, name](double time, const trompo::SO3<double>& R, const V3& W) -> double {
    py::gil_scoped_acquire gil;
    py::array_t<double> y(12);
    auto yv = y.mutable_unchecked<1>();
    const M3 L = R.matrix();
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) yv(3 * i + j) = L(i, j);
    for (int i = 0; i < 3; ++i) yv(9 + i) = W(i);
    try {
      return py::reinterpret_borrow<py::object>(fn)(time, y).cast<double>();
    } catch (py::error_already_set& err) {
      throw std::runtime_error("event '" + name + "' raised " + err.what());
    } catch (const py::cast_error&) {
      throw std::runtime_error("event '" + name + "': the function must return a number");
    }
  };
  return e;
}

/// A Python torque law raised (its exception is kept by simulate_flags): ends the run.
struct LawRaised {};

/// (Λ, Ω) as NumPy arrays (3, 3) and (3,), for a call into Python (the GIL held).
std::pair<py::array_t<double>, py::array_t<double>> arrays_of(const M3& Lambda, const V3& omega) {
  py::array_t<double> R({3, 3});
  py::array_t<double> W(3);
  double* r = R.mutable_data();
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) r[3 * i + j] = Lambda(i, j);
  for (int i = 0; i < 3; ++i) W.mutable_data()[i] = omega(i);
  return {R, W};
}

/// A trompo.TorqueLaw's callables as the engine's CodeTorque: tau(t, R, W) -> 3 numbers and,
/// optionally, jacobian(t, R, W) -> (D_w, D_Omega), two 3x3 arrays. Each call takes the GIL
/// (the engine runs without it). The callables are held by pointer (the caller keeps them
/// alive for the run). An exception (or a value of the wrong shape) is kept in `raised` and
/// ends the run; simulate_flags raises it again with its traceback.
CodeTorque python_torque_law(const py::handle& torque, const py::handle& jacobian, py::object* raised) {
  CodeTorque law;
  if (torque.is_none()) return law;
  PyObject* fn = torque.ptr();
  // Calls `body` (a call into Python) with the GIL held. An exception is kept in `raised` and
  // the engine's call fails with LawRaised: Python's own (with its traceback), a cast failure
  // as ValueError(`wrong_shape`), a ValueError the body threw as itself.
  auto into_python = [raised](const char* wrong_shape, auto&& body) {
    py::gil_scoped_acquire gil;
    try {
      return body();
    } catch (py::error_already_set& e) {
      *raised = e.value();
      if (e.trace()) PyException_SetTraceback(raised->ptr(), e.trace().ptr());
    } catch (const py::cast_error&) {
      *raised = py::reinterpret_steal<py::object>(PyObject_CallFunction(PyExc_ValueError, "s", wrong_shape));
    } catch (const py::builtin_exception& e) {
      *raised = py::reinterpret_steal<py::object>(PyObject_CallFunction(PyExc_ValueError, "s", e.what()));
    }
    throw LawRaised{};
  };
  law.torque = [fn, into_python](double t, const M3& Lambda, const V3& omega) -> V3 {
    return into_python("TorqueLaw: the law must return 3 numbers", [&] {
      auto [R, W] = arrays_of(Lambda, omega);
      const Array tau = py::cast<Array>(py::reinterpret_borrow<py::object>(fn)(t, R, W));
      if (tau.size() != 3 || tau.ndim() != 1)
        throw py::value_error("TorqueLaw: the law must return 3 numbers, got shape (" + std::to_string(tau.size()) + ",)");
      return V3(tau.data()[0], tau.data()[1], tau.data()[2]);
    });
  };
  if (jacobian.is_none()) return law;
  PyObject* jac = jacobian.ptr();
  law.jacobians = [jac, into_python](double t, const M3& Lambda, const V3& omega, M3& D_w, M3& D_v) {
    into_python("TorqueLaw: the jacobian must return two 3x3 arrays (D_w, D_Omega)", [&] {
      auto [R, W] = arrays_of(Lambda, omega);
      const py::tuple out = py::cast<py::tuple>(py::reinterpret_borrow<py::object>(jac)(t, R, W));
      if (out.size() != 2) throw py::value_error("TorqueLaw: the jacobian must return (D_w, D_Omega)");
      const Array a = py::cast<Array>(out[0]), b = py::cast<Array>(out[1]);
      if (!(a.ndim() == 2 && a.shape(0) == 3 && a.shape(1) == 3 && b.ndim() == 2 && b.shape(0) == 3 && b.shape(1) == 3))
        throw py::value_error("TorqueLaw: the jacobian must return two 3x3 arrays (D_w, D_Omega)");
      D_w = Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>>(a.data());
      D_v = Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>>(b.data());
    });
  };
  return law;
}

/// (status, rows, messages): status is the CLI's exit code (0 done, 3 a step failed).
/// `events`: Python event functions, (name, callable, direction, terminal) each, after the
/// flags' --event (adaptive steps only). `rotation`: the initial attitude as a matrix (body
/// -> space) in place of --rotation. `laws`: trompo.TorqueLaw's callables, (body torque,
/// body jacobian, space torque, space jacobian), each None or a callable.
py::tuple simulate_flags(const std::map<std::string, std::string>& flags, const py::object& events,
                         const std::optional<Array>& rotation, const py::object& laws) {
  Config c = parse_config(flags);
  if (!c.ensemble.empty() || !c.csv.empty()) throw py::value_error("simulate: --ensemble and --csv are the CLI's");
  if (!events.is_none()) {
    if (!c.adaptive.on) throw py::value_error("events: only with adaptive steps (give rtol)");
    for (const py::handle& item : events) c.adaptive.code_events.push_back(python_event(item));
  }
  if (rotation) {
    if (!(rotation->ndim() == 2 && rotation->shape(0) == 3 && rotation->shape(1) == 3))
      throw py::value_error("rotation: expected (3, 3)");
    c.rotation_matrix = Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>>(rotation->data());
  }
  py::object law_raised = py::none();  // a torque law's exception (set with the GIL held)
  if (!laws.is_none()) {
    const py::tuple l = py::reinterpret_borrow<py::tuple>(laws);
    if (l.size() != 4) throw py::value_error("laws: expected (body, body jacobian, space, space jacobian)");
    c.body_law = python_torque_law(l[0], l[1], &law_raised);
    c.space_law = python_torque_law(l[2], l[3], &law_raised);
    if (c.code_torques() && c.adaptive.picked) {
      // The picked method (the splitting) is not compiled for laws as code: Simo-kappa's
      // order-6 composition instead, named on the summary line as any pick.
      c.scheme = "simo-kappa";
      c.order = 6;
    }
  }
  try {
    validate(c);
  } catch (const invalid_input& e) {
    throw py::value_error(e.what());
  }
  ArraySink sink;
  // a guess, capped (an adaptive run without --dt: its steps are unknown)
  const double rows = c.dt ? std::abs(*c.t_end / *c.dt) / static_cast<double>(c.every) + 2 : 1e3;
  sink.reserve(static_cast<std::size_t>(std::min(rows, 1e5)));
  int code = 0;
  std::string error, raised;
  {
    py::gil_scoped_release no_gil;
    try {
      code = simulate(c, sink);
    } catch (const invalid_input& e) {
      error = e.what();
    } catch (const std::runtime_error& e) {  // an event function raised (python_event)
      raised = e.what();
    } catch (const LawRaised&) {  // a torque law raised: its own exception, below
    }
  }
  if (!law_raised.is_none()) {
    // marked, so that trompo's wrapper passes it on as raised (not as an engine message)
    if (PyObject_SetAttrString(law_raised.ptr(), "trompo_torque_law", Py_True) != 0) PyErr_Clear();
    PyErr_SetObject(reinterpret_cast<PyObject*>(Py_TYPE(law_raised.ptr())), law_raised.ptr());
    throw py::error_already_set();
  }
  if (!error.empty()) throw py::value_error(error);
  if (!raised.empty()) throw std::runtime_error(raised);
  py::list messages;
  for (const auto& m : sink.messages) messages.append(m);
  return py::make_tuple(code, rows_of(sink), messages);
}


/// 3×3 row-major from an array already checked to be (3, 3).
M3 matrix_of(const Array& a) { return Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>>(a.data()); }

/// mrp-pd's target rotation, a (3, 3) array; ValueError naming `target` otherwise.
M3 target_of(const Array& target) {
  if (!(target.ndim() == 2 && target.shape(0) == 3 && target.shape(1) == 3)) throw py::value_error("target: expected (3, 3)");
  return matrix_of(target);
}

/// The wheels of a trompo.Spacecraft into the Config: `wheels` (N, 5) rows axis(3), Js, speed0,
/// `limits` (N, 2) max_torque, max_speed or (N, 3) with the viscous friction c as well [W17];
/// each checked as the library checks it (naming the wheel), then the control flags again
/// (mrp-pd needs axes spanning 3-D, friction fixed steps).
void set_wheels(Config& c, const std::map<std::string, std::string>& flags, const Array& wheels, const Array& limits) {
  if (!(wheels.ndim() == 2 && wheels.shape(1) == 5 && limits.ndim() == 2 &&
        (limits.shape(1) == 2 || limits.shape(1) == 3) && limits.shape(0) == wheels.shape(0)))
    throw py::value_error("wheels: expected (N, 5) and (N, 2) or (N, 3) arrays");
  const py::ssize_t columns = limits.shape(1);
  for (py::ssize_t i = 0; i < wheels.shape(0); ++i) {
    const double* w = wheels.data() + 5 * i;
    trompo::Wheel<double> wheel;
    wheel.axis = V3(w[0], w[1], w[2]);
    wheel.inertia = w[3];
    wheel.speed0 = w[4];
    wheel.max_torque = limits.data()[columns * i];
    wheel.max_speed = limits.data()[columns * i + 1];
    if (columns == 3) wheel.friction = limits.data()[columns * i + 2];
    trompo::ReactionWheels<double>().add_wheel(wheel);  // its checks, naming the wheel
    c.control.wheels.push_back(wheel);
  }
  if (!c.control.wheels.empty()) c.control.wheels_file = "(trompo.Spacecraft)";
  check_control(c, flags);
}

/// The ensemble: members from arrays, final states out as arrays.
py::dict ensemble_flags(const std::map<std::string, std::string>& flags, const Array& rotation, const Array& omega,
                        const std::optional<Array>& mgl, const std::optional<Array>& inertia, const py::object& progress,
                        const std::optional<Array>& wheels, const std::optional<Array>& limits,
                        const std::optional<Array>& target) {
  Config c = config_of(flags);
  if (wheels) {  // a closed-loop ensemble (trompo.control_ensemble)
    if (!limits) throw py::value_error("limits: needed with wheels");
    try {
      set_wheels(c, flags, *wheels, *limits);
    } catch (const invalid_input& e) {
      throw py::value_error(e.what());
    }
  }
  if (target) c.control.target_matrix = target_of(*target);
  auto shape = [](const Array& a) {
    std::string s = "(";
    for (py::ssize_t k = 0; k < a.ndim(); ++k) s += (k ? ", " : "") + std::to_string(a.shape(k));
    return s + (a.ndim() == 1 ? ",)" : ")");
  };
  if (!(rotation.ndim() == 2 && rotation.shape(1) == 3) && !(rotation.ndim() == 3 && rotation.shape(1) == 3 && rotation.shape(2) == 3))
    throw py::value_error("rotation: expected rotation vectors (N, 3) or matrices (N, 3, 3), got shape " + shape(rotation));
  const auto n = static_cast<std::size_t>(rotation.shape(0));
  if (n == 0) throw py::value_error("rotation: no members (N = 0)");
  if (!(omega.ndim() == 2 && omega.shape(1) == 3 && static_cast<std::size_t>(omega.shape(0)) == n))
    throw py::value_error("omega: expected shape (" + std::to_string(n) + ", 3), got " + shape(omega));
  if (mgl && !(mgl->ndim() == 1 && static_cast<std::size_t>(mgl->shape(0)) == n))
    throw py::value_error("mgl: expected shape (" + std::to_string(n) + ",), got " + shape(*mgl));
  if (inertia && !(inertia->ndim() == 2 && static_cast<std::size_t>(inertia->shape(0)) == n &&
                   (inertia->shape(1) == 3 || inertia->shape(1) == 6)) &&
      !(inertia->ndim() == 3 && static_cast<std::size_t>(inertia->shape(0)) == n && inertia->shape(1) == 3 &&
        inertia->shape(2) == 3))
    throw py::value_error("inertia: expected shape (" + std::to_string(n) + ", 3), (" + std::to_string(n) + ", 6) or (" +
                          std::to_string(n) + ", 3, 3), got " + shape(*inertia));

  EnsembleInput in;
  in.rotation.reserve(n);
  in.omega.reserve(n);
  const double* r = rotation.data();
  const double* w = omega.data();
  for (std::size_t i = 0; i < n; ++i) {
    try {
      if (rotation.ndim() == 2) {
        const V3 x(r[3 * i], r[3 * i + 1], r[3 * i + 2]);
        if (!trompo::detail::all_finite(x)) throw invalid_input("rotation: not finite " + trompo::detail::to_text(x));
        in.rotation.push_back(attitude_of(x, "rotation"));
      } else {
        in.rotation.push_back(trompo::SO3d::from_matrix(Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>>(r + 9 * i)));
      }
      in.omega.emplace_back(w[3 * i], w[3 * i + 1], w[3 * i + 2]);
      if (mgl) in.mgl.push_back(mgl->data()[i]);
      if (inertia) {
        const double* j = inertia->data();
        M3 J = M3::Zero();
        if (inertia->ndim() == 3) {
          J = Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>>(j + 9 * i);
        } else if (inertia->shape(1) == 3) {
          J.diagonal() << j[3 * i], j[3 * i + 1], j[3 * i + 2];
        } else {
          const double* v = j + 6 * i;  // J11,J22,J33,J12,J13,J23 as --inertia
          J.diagonal() << v[0], v[1], v[2];
          J(0, 1) = J(1, 0) = v[3];
          J(0, 2) = J(2, 0) = v[4];
          J(1, 2) = J(2, 1) = v[5];
        }
        in.inertia.push_back(J);
      }
      validate_member(c, in, i);
    } catch (const invalid_input& e) {
      throw py::value_error("member " + std::to_string(i) + ": " + e.what());
    }
  }

  EnsembleRun run(in);
  py::object progress_raised = py::none();  // the progress function's exception, raised after the run
  if (!progress.is_none()) {
    // Called from the thread that finished a chunk, one call at a time, with the GIL taken;
    // held by pointer (the caller keeps it alive for the run). After an exception it is not
    // called again.
    PyObject* fn = progress.ptr();
    py::object* raised = &progress_raised;
    run.progress = [fn, raised](std::size_t done, std::size_t total) {
      py::gil_scoped_acquire gil;
      if (!raised->is_none()) return;
      try {
        py::reinterpret_borrow<py::object>(fn)(done, total);
      } catch (py::error_already_set& e) {
        *raised = e.value();
        if (e.trace()) PyException_SetTraceback(raised->ptr(), e.trace().ptr());
      }
    };
  }
  std::string error;
  {
    py::gil_scoped_release no_gil;
    try {
      simulate(c, run);
    } catch (const invalid_input& e) {
      error = e.what();
    }
  }
  if (!error.empty()) throw py::value_error(error);
  if (!progress_raised.is_none()) {
    PyErr_SetObject(reinterpret_cast<PyObject*>(Py_TYPE(progress_raised.ptr())), progress_raised.ptr());
    throw py::error_already_set();
  }

  ArraySink rows;
  rows.reserve(n);
  std::vector<std::int64_t> recovered(n);
  std::vector<bool> ok(n);
  py::list status;
  for (std::size_t i = 0; i < n; ++i) {
    const auto& s = run.states[i];
    rows.row(s.time, s.rotation.matrix(), s.omega, run.energy[i], run.momentum_map[i], run.spatial_momentum[i],
             static_cast<long>(run.iterations(i)));
    recovered[i] = run.summaries.empty() ? 0 : run.summaries[i].recovered;
    status.append(run.reason(i));
    ok[i] = run.ok(i);
  }
  py::dict d = rows_of(rows);
  py::array_t<bool> ok_array(static_cast<py::ssize_t>(n));
  for (std::size_t i = 0; i < n; ++i) ok_array.mutable_data()[i] = ok[i];
  d["ok"] = ok_array;
  d["status"] = status;
  d["recovered"] = to_array(std::move(recovered), {static_cast<py::ssize_t>(n)});
  py::list messages;
  for (const auto& m : run.messages) messages.append(m);
  d["messages"] = messages;
  if (!run.sampled.empty()) {  // closed loops: each member's wheels at the end and its samples
    const auto N = static_cast<py::ssize_t>(n), W = static_cast<py::ssize_t>(run.wheels);
    std::vector<double> speeds(n * static_cast<std::size_t>(run.wheels)), torques(speeds.size());
    std::vector<std::int64_t> samples(n);
    for (std::size_t i = 0; i < n; ++i) {
      for (int j = 0; j < run.wheels; ++j) {
        speeds[i * static_cast<std::size_t>(run.wheels) + static_cast<std::size_t>(j)] = run.sampled[i].wheel_speeds(j);
        torques[i * static_cast<std::size_t>(run.wheels) + static_cast<std::size_t>(j)] = run.sampled[i].wheel_torques(j);
      }
      samples[i] = run.sampled[i].summary.samples;
    }
    d["wheel_speeds"] = to_array(std::move(speeds), {N, W});
    d["u"] = to_array(std::move(torques), {N, W});
    d["samples"] = to_array(std::move(samples), {N});
  }
  if (run.adaptive.empty()) return d;
  // ---- adaptive members (--rtol): the driver's counts, the states at t_eval, the events ----
  const auto N = static_cast<py::ssize_t>(n);
  std::vector<std::int64_t> accepted(n), rejected(n), failures(n);
  for (std::size_t i = 0; i < n; ++i) {
    accepted[i] = run.adaptive[i].accepted;
    rejected[i] = run.adaptive[i].rejected;
    failures[i] = run.adaptive[i].failures;
  }
  d["nsteps"] = to_array(std::move(accepted), {N});
  d["nreject"] = to_array(std::move(rejected), {N});
  d["nfail"] = to_array(std::move(failures), {N});
  // y of member i at t_eval: (12, m), Λ row-major then Ω, as solve_ivp's; NaN past a failure
  auto columns = [](const trompo::State<double>& s, double* y, std::size_t stride, std::size_t k) {
    const M3 L = s.rotation.matrix();
    for (int a = 0; a < 3; ++a)
      for (int b = 0; b < 3; ++b) y[static_cast<std::size_t>(3 * a + b) * stride + k] = L(a, b);
    for (int a = 0; a < 3; ++a) y[static_cast<std::size_t>(9 + a) * stride + k] = s.omega(a);
  };
  const std::size_t m = c.adaptive.t_eval.size();
  if (m > 0) {
    std::vector<double> y(n * 12 * m, std::numeric_limits<double>::quiet_NaN());
    for (std::size_t i = 0; i < n; ++i)
      for (std::size_t k = 0; k < run.at_times[i].size() && k < m; ++k) columns(run.at_times[i][k], y.data() + i * 12 * m, m, k);
    d["y_eval"] = to_array(std::move(y), {N, 12, static_cast<py::ssize_t>(m)});
  }
  py::list t_events, y_events;
  for (std::size_t i = 0; i < n; ++i) {
    py::list ti, yi;
    for (const auto& found : run.events[i]) {
      const std::size_t k = found.size();
      std::vector<double> t(k), yy(k * 12);
      for (std::size_t j = 0; j < k; ++j) {
        t[j] = found[j].time;
        columns(found[j], yy.data() + 12 * j, 1, 0);  // row j: the 12 numbers
      }
      ti.append(to_array(std::move(t), {static_cast<py::ssize_t>(k)}));
      yi.append(to_array(std::move(yy), {static_cast<py::ssize_t>(k), 12}));
    }
    t_events.append(ti);
    y_events.append(yi);
  }
  d["t_events"] = t_events;
  d["y_events"] = y_events;
  return d;
}

// ---- control in the loop (trompo.control; docs/python.md "Control in the loop") ----

/// simulate()'s rows and, per row, the wheels' speeds (relative to the body) and the motor
/// torques held from that row on.
class ControlSink final : public ArraySink {
 public:
  std::vector<double> speeds, torques;
  int wheels = 0;
  void wheel_header(int n) override { wheels = n; }
  void wheel_row(double t_, const M3& R_, const V3& W_, double H_, double mu_, const V3& pi_, long iterations_,
                 const double* w, const double* u, int n) override {
    row(t_, R_, W_, H_, mu_, pi_, iterations_);
    speeds.insert(speeds.end(), w, w + n);
    torques.insert(torques.end(), u, u + n);
  }
};

/// A Python controller raised (its exception is kept by control_run): ends the run through
/// the driver, whose rows so far stay in the sink.
struct ControllerRaised {};


/// A command's entry from Python: a 1-D array of `want` numbers (-1: up to max_wheels).
template <class Vec>
Vec command_entry(const char* name, const py::handle& value, int want) {
  const Array a = py::cast<Array>(value);
  const auto n = a.size();
  if (a.ndim() > 1 || (want >= 0 && n != want) || n > trompo::ReactionWheels<double>::max_wheels)
    throw py::value_error(std::string("controller: '") + name + "' must be " +
                          (want >= 0 ? std::to_string(want) + " numbers" : std::string("one number per wheel")) +
                          ", got " + std::to_string(n));
  Vec v;
  v.resize(n);
  for (py::ssize_t i = 0; i < n; ++i) v(i) = a.data()[i];
  return v;
}

/// The dict a Python controller returns as a Command (None: no command, u = 0). `field`:
/// whether the spacecraft has an orbit (ControlScene always has magnetorquers, in a
/// placeholder field without one: a dipole is refused there).
trompo::Command<double> command_of(const py::handle& out, bool field) {
  trompo::Command<double> c;
  if (out.is_none()) return c;
  if (!py::isinstance<py::dict>(out))
    throw py::type_error("controller: must return a dict with keys 'wheel_torques', 'body_torque', 'dipole' (or None), got " +
                         std::string(py::str(py::type::of(out).attr("__name__"))));
  for (const auto& [key, value] : py::reinterpret_borrow<py::dict>(out)) {
    const std::string k = py::isinstance<py::str>(key) ? key.cast<std::string>() : std::string(py::repr(key));
    if (k == "wheel_torques") c.wheel_torques = command_entry<trompo::ReactionWheels<double>::WheelVector>("wheel_torques", value, -1);
    else if (k == "body_torque") c.body_torque = command_entry<V3>("body_torque", value, 3);
    else if (k == "dipole") c.dipole = command_entry<V3>("dipole", value, 3);
    else throw py::value_error("controller: unknown command '" + k + "' (wheel_torques, body_torque, dipole)");
  }
  if (!field && c.dipole != V3::Zero())
    throw py::value_error("controller: dipole commanded, but the spacecraft has no orbit (no magnetic field)");
  return c;
}

/// One control run: trompo-simulate's control path (ControlScene, integrate_sampled with
/// FixedSteps of --dt, the same dispatch over --scheme/--order) on the spacecraft given as
/// arrays. `flags`: the CLI's (--inertia, --dt, --t-end, --every, --scheme, --order,
/// --controller mrp-pd:K,P|bdot:k|code, --control-period, --orbit-*, --max-dipole);
/// `wheels`: (N, 5) rows axis(3), Js, speed0 then max_torque, max_speed[, friction] in `limits` (N, 2|3);
/// `rotation` (3, 3) body -> space, `omega` (3,); `target` mrp-pd's (3, 3); `controller`
/// a callable f(t, R, W, wheel_speeds, memory) for --controller code; `events` Python event
/// functions as simulate_flags' (with --rtol: adaptive steps over each hold). The GIL is released
/// while C++ integrates and taken at each sample for the callable only.
/// Returns (status, rows, messages, raised, t): raised is the controller's exception or
/// None, t the time of the sample that raised.
py::tuple control_run(const std::map<std::string, std::string>& flags, const Array& wheels, const Array& limits,
                      const Array& rotation, const Array& omega, const std::optional<Array>& target,
                      const py::object& controller, const py::object& memory, const py::object& events) {
  if (!(rotation.ndim() == 2 && rotation.shape(0) == 3 && rotation.shape(1) == 3)) throw py::value_error("rotation: expected (3, 3)");
  if (!(omega.ndim() == 1 && omega.shape(0) == 3)) throw py::value_error("omega: expected (3,)");
  const std::optional<M3> target_matrix = target ? std::optional<M3>(target_of(*target)) : std::nullopt;
  py::object raised = py::none();  // the controller's exception (set with the GIL held)
  double raised_at = std::numeric_limits<double>::quiet_NaN();  // its sample's t_k
  Config c;
  try {
    c = parse_flags(flags);
    if (!events.is_none()) {  // Python event functions (adaptive steps only), as simulate_flags'
      if (!c.adaptive.on) throw py::value_error("events: only with adaptive steps (give rtol)");
      for (const py::handle& item : events) c.adaptive.code_events.push_back(python_event(item));
    }
    set_wheels(c, flags, wheels, limits);  // then check_control, which sees the events too (terminal, friction)
    c.rotation_matrix = matrix_of(rotation);
    c.omega = V3(omega.data()[0], omega.data()[1], omega.data()[2]);
    if (target_matrix) c.control.target_matrix = target_matrix;
    if (!controller.is_none()) {
      // Held by pointer (the caller keeps them alive for the run): copies of the function
      // touch no Python reference count without the GIL.
      PyObject* fn = controller.ptr();
      PyObject* mem = memory.ptr();
      py::object* out = &raised;
      double* at = &raised_at;
      const bool field = c.control.orbit_radius.has_value();
      c.control.code = [fn, mem, out, at, field](const trompo::Sample<double>& s) -> trompo::Command<double> {
        py::gil_scoped_acquire gil;
        *at = s.time;
        try {
          py::array_t<double> R({3, 3});
          py::array_t<double> W(3);
          const auto n = static_cast<py::ssize_t>(s.wheel_speeds.size());
          py::array_t<double> w(n);
          const M3 L = s.state.rotation.matrix();
          double* r = R.mutable_data();
          for (int i = 0; i < 3; ++i)
            for (int j = 0; j < 3; ++j) r[3 * i + j] = L(i, j);
          for (int i = 0; i < 3; ++i) W.mutable_data()[i] = s.state.omega(i);
          for (py::ssize_t i = 0; i < n; ++i) w.mutable_data()[i] = s.wheel_speeds(i);
          return command_of(py::reinterpret_borrow<py::object>(fn)(s.time, R, W, w, py::handle(mem)), field);
        } catch (py::error_already_set& e) {
          *out = e.value();
          // The traceback (the controller's frames) on the exception itself, so that it
          // survives as the trompo error's __cause__.
          if (e.trace()) PyException_SetTraceback(out->ptr(), e.trace().ptr());
        } catch (const py::cast_error& e) {  // a command that is no array of numbers
          *out = py::reinterpret_steal<py::object>(
              PyObject_CallFunction(PyExc_TypeError, "s", (std::string("controller: a command must be numbers: ") + e.what()).c_str()));
        } catch (const py::builtin_exception& e) {  // command_of's: as the Python exception
          e.set_error();
          *out = py::error_already_set().value();
        }
        throw ControllerRaised{};
      };
    }
    validate(c);
  } catch (const invalid_input& e) {
    throw py::value_error(e.what());
  }
  ControlSink sink;
  int code = 0;
  std::string error;
  bool stopped = false;
  {
    py::gil_scoped_release no_gil;
    try {
      code = simulate(c, sink);
    } catch (const invalid_input& e) {
      error = e.what();
    } catch (const ControllerRaised&) {
      stopped = true;
    }
  }
  if (!error.empty()) throw py::value_error(error);
  const auto rows = static_cast<py::ssize_t>(sink.t.size());
  const auto n = static_cast<py::ssize_t>(c.control.wheels.size());
  sink.speeds.resize(static_cast<std::size_t>(rows * n));  // wheel_row writes them; none if no row
  sink.torques.resize(static_cast<std::size_t>(rows * n));
  std::vector<double> speeds = std::move(sink.speeds), torques = std::move(sink.torques);
  py::dict d = rows_of(sink);
  d["wheel_speeds"] = to_array(std::move(speeds), {rows, n});
  d["u"] = to_array(std::move(torques), {rows, n});
  py::list messages;
  for (const auto& m : sink.messages) messages.append(m);
  return py::make_tuple(stopped ? -1 : code, d, messages, raised, raised_at);
}

}  // namespace

PYBIND11_MODULE(_trompo, m) {
  m.doc() = "C++ half of the trompo module: trompo-simulate's logic on NumPy arrays (use trompo.simulate / trompo.ensemble)";
  m.def("simulate_flags", &simulate_flags, py::arg("flags"), py::arg("events") = py::none(),
        py::arg("rotation") = py::none(), py::arg("laws") = py::none(),
        "Runs trompo-simulate's flags (a dict '--dt' -> '0.001'), with optional Python event functions "
        "[(name, g(t, y), direction, terminal), ...], an initial rotation matrix and torque laws "
        "(body, body jacobian, space, space jacobian); returns (status, rows, messages).");
  m.def("ensemble_flags", &ensemble_flags, py::arg("flags"), py::arg("rotation"), py::arg("omega"),
        py::arg("mgl") = py::none(), py::arg("inertia") = py::none(), py::arg("progress") = py::none(),
        py::arg("wheels") = py::none(), py::arg("limits") = py::none(), py::arg("target") = py::none(),
        "Integrates every member (rows of rotation/omega) with trompo-simulate's flags; final states as arrays. "
        "With wheels (N, 5), limits (N, 2) and an mrp-pd target (3, 3): closed loops (trompo.control_ensemble).");
  m.def("control_run", &control_run, py::arg("flags"), py::arg("wheels"), py::arg("limits"), py::arg("rotation"),
        py::arg("omega"), py::arg("target") = py::none(), py::arg("controller") = py::none(),
        py::arg("memory") = py::none(), py::arg("events") = py::none(),
        "One control run (trompo.control): returns (status, rows, messages, raised, t); status -1: the controller raised at t.");
  m.def("usage", &usage, "trompo-simulate --help");
  m.attr("__version__") = TROMPO_VERSION;
}
