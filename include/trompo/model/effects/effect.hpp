#pragma once
// The effect concept: what a scene may add to the free rigid body (docs/theory.md §1, §5).
//
// An effect is a small value type with a `kind` tag and a per-step `Cache`, computed
// once per step from the attitude Λ_n at the start of the step and the mid time:
//
//   typename E::Cache cache(const Matrix3& Lambda_n, Scalar t_mid) const;
//
// (An effect that reads the reaction wheels' state declares `static constexpr bool
// reads_wheels = true` and `using Wheels = ReactionWheels<Scalar>`; the scene then calls
// cache(Lambda_n, t_mid, wheels) with its own wheels effect: a torque law of the wheels'
// speeds, torque_law.hpp [W15].)
//
// and, by kind, these members. Every torque is returned in the body frame of step n
// (the frame in which the Simo residual [T1] is written); "R" is the rotation relative
// to Λ_n of the configuration where it acts, Λ = Λ_n R, and a Jacobian "w.r.t. w" is
// the derivative for the right perturbation Λ_n R exp(ŵ).
//
//  potential_kind   (conservative; enters H)
//     Scalar  potential(const Cache&, const Matrix3& R) const;          // V(Λ_n R)
//     Vector3 torque(const Cache&, const Matrix3& R) const;             // R·(−∂V), frame n
//     Matrix3 torque_jacobian(const Cache&, const Matrix3& R) const;    // ∂torque/∂w
//     static constexpr bool linear_in_rotation;  // V = tr(AΛ) + c: closed forms for the
//                                                // Simo-κ factor (19) and α of [T2] hold
//     optional:
//     Vector3 torque_rodrigues(const Cache&, const Vector3& x, Scalar a, Scalar b) const;
//                              // torque(R) for R = I + a x̂ + b x̂² (8), without forming R
//                              // (gravity rotates one body vector: two cross products)
//  torque_kind      (applied at the step's mid configuration and mid velocity, §5)
//     Vector3 torque(const Cache&, const Matrix3& R_mid, const Vector3& omega_mid) const;
//     Matrix3 torque_jacobian_rotation(const Cache&, const Matrix3& R_mid, const Vector3& omega_mid) const;
//     Matrix3 torque_jacobian_omega(const Cache&, const Matrix3& R_mid, const Vector3& omega_mid) const;
//  rotor_kind       (internal angular momentum: Π = JΩ + h_r)
//     Vector3 rotor_momentum() const;
//
// The scene assembles exactly the effects it lists (scene.hpp); an effect it does not
// list is not called, not branched on and not added as a zero.

namespace trompo {

struct potential_kind {};
struct torque_kind {};
struct rotor_kind {};

}  // namespace trompo
