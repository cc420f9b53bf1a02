#pragma once
// B-dot detumbling (docs/theory.md [W13]; docs/control.md): m = −k Ḃ_body, with Ḃ the
// difference of the field sampled in body axes at two samples, clipped per axis by the
// magnetorquers. The first sample has no previous field and commands m = 0.
#include <Eigen/Core>

#include "trompo/control/command.hpp"
#include "trompo/errors.hpp"

namespace trompo {

/// bdot:k — m = −k (b_k − b_{k−1})/(t_k − t_{k−1}) [W13]; its memory is the last sample.
template <class Scalar>
struct BDot {
  /// A 3-vector of Scalar.
  using Vector3 = Eigen::Matrix<Scalar, 3, 1>;
  Scalar k = Scalar(0);  ///< gain (A m² s / T)
  // memory
  Vector3 last_field = Vector3::Zero();  ///< b_{k−1}
  Scalar last_time = Scalar(0);          ///< t_{k−1}
  bool have_last = false;                ///< whether b_{k−1} exists

  /// Throws invalid_input unless k ≥ 0 finite.
  void validate() const {
    if (!std::isfinite(static_cast<double>(k)) || !(k >= Scalar(0))) detail::fail("bdot: k must be finite and >= 0, got ", k);
  }

  /// The command (the driver saturates it by the magnetorquers' limits).
  Command<Scalar> operator()(const Sample<Scalar>& s) {
    if (!s.has_field) detail::fail("bdot: the scene has no magnetorquers (no field to sample)");
    Command<Scalar> c;
    if (have_last && s.time != last_time) c.dipole = -k * (s.field - last_field) / (s.time - last_time);
    last_field = s.field;
    last_time = s.time;
    have_last = true;
    return c;
  }
};

}  // namespace trompo
