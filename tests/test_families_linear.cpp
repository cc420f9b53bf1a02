// Caveat 1 of docs/theory.md §11: the α convention of [T7] checked where it is defined, on
// x″ = −ω²x. The step of LieGenAlpha ([T8], with Λ replaced by x and the equation of motion
// by ẍ = −ω²x) is applied to the four unit states (x, v, ẍ, a); the spectral radius of the
// resulting amplification matrix at ωh = 10⁶ must be ρ∞ (and 1 at ωh → 0).
#include <catch2/catch.hpp>

#include <Eigen/Dense>
#include <Eigen/Eigenvalues>

#include "trompo/schemes/families/lie_gen_alpha.hpp"

namespace {

/// One gen-α step of x″ = −ω²x with the coefficients of `s` ([T7], [T8]); state (x, v, ẍ, a).
Eigen::Vector4d step(const trompo::LieGenAlpha& s, const Eigen::Vector4d& y, double omega_h) {
  const auto c = s.coefficients();
  const double h = 1.0, w2 = omega_h * omega_h;
  const double x = y(0), v = y(1), xdd = y(2), a = y(3);
  // a1 = p + q w, x1 = x + h v + h²(½ − β)a + h²β a1, and w = −ω² x1: solve the scalar equation.
  const double q = (1 - c.alpha_f) / (1 - c.alpha_m);
  const double p = (c.alpha_f * xdd - c.alpha_m * a) / (1 - c.alpha_m);
  const double x0 = x + h * v + h * h * (0.5 - c.beta) * a + h * h * c.beta * p;  // x1 = x0 + h²βq w
  const double w = -w2 * x0 / (1 + w2 * h * h * c.beta * q);
  const double a1 = p + q * w;
  const double x1 = x0 + h * h * c.beta * q * w;
  const double v1 = v + h * (1 - c.gamma) * a + h * c.gamma * a1;
  return {x1, v1, w, a1};
}

double spectral_radius(const trompo::LieGenAlpha& s, double omega_h) {
  Eigen::Matrix4d A;
  for (int j = 0; j < 4; ++j) A.col(j) = step(s, Eigen::Vector4d::Unit(j), omega_h);
  return Eigen::EigenSolver<Eigen::Matrix4d>(A).eigenvalues().cwiseAbs().maxCoeff();
}

}  // namespace

TEST_CASE("Gen-alpha coefficients [T7]: spectral radius rho_inf at omega h = 1e6 and 1 as omega h -> 0", "[families][gen-alpha]") {
  for (double rho : {0.0, 0.5, 0.8, 1.0}) {
    const trompo::LieGenAlpha s(rho);
    const double r = spectral_radius(s, 1e6);
    INFO("rho_inf " << rho << ": spectral radius " << r);
    CHECK(std::abs(r - rho) <= 1e-3);
    CHECK(std::abs(spectral_radius(s, 1e-3) - 1.0) <= 1e-5);
  }
}
