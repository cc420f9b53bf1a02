#pragma once
// The one exception trompo throws: bad input, named with its field and value.
// Steps never throw for numerical trouble; they return a StepReport (stepper.hpp).
#include <Eigen/Core>
#include <cmath>
#include <sstream>
#include <stdexcept>
#include <string>

namespace trompo {

/// Thrown by constructors and validators on invalid input (non-finite numbers, an
/// inertia that is not a rigid body's, a matrix that is not a rotation, Δt = 0, …).
/// `what()` names the field and the offending value.
class invalid_input : public std::invalid_argument {
 public:
  using std::invalid_argument::invalid_argument;
};

namespace detail {

template <class... Parts>
[[noreturn]] void fail(const Parts&... parts) {
  std::ostringstream os;
  os.precision(17);
  (os << ... << parts);
  throw invalid_input(os.str());
}

template <class Derived>
bool all_finite(const Derived& m) {
  using std::isfinite;  // in the Scalar's own type: a long double beyond 1e308 is finite
  for (Eigen::Index i = 0; i < m.size(); ++i)
    if (!isfinite(m.data()[i])) return false;
  return true;
}

template <class Derived>
std::string to_text(const Derived& m) {
  std::ostringstream os;
  os.precision(17);
  os << '(';
  for (Eigen::Index i = 0; i < m.size(); ++i) os << (i ? ", " : "") << m.data()[i];
  os << ')';
  return os.str();
}

}  // namespace detail
}  // namespace trompo
