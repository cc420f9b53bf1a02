#pragma once
// The coefficient tables of the composition methods (docs/theory.md §6, §13 [P4], [P5]),
// below the schemes so that a scheme may build its own schedule from them (Splitting's
// Suzuki and Kahan–Li compositions of its Strang step) and the steppers theirs
// (ComposedStepper, ProcessedStepper). Numbers only: no stepping here.
//
//   triple jump   order 4, s = 3     Suzuki-5      order 4, s = 5
//   Kahan–Li 9    order 6, s = 9     McLachlan 15  order 8, s = 15
//   Kahan–Li 17   order 8, s = 17    Blanes–Casas–Murua: order-6 kernel s = 13, processor 12
#include <array>
#include <cstddef>

#include "trompo/errors.hpp"

namespace trompo {

/// The symmetric compositions on offer.
enum class Composition {
  base,         ///< order 2: one step of the base scheme
  triple_jump,  ///< order 4, 3 steps
  suzuki5,      ///< order 4, 5 steps (Suzuki 1990)
  kahan_li9,    ///< order 6, 9 steps (Kahan & Li 1997)
  mclachlan15,  ///< order 8, 15 steps (McLachlan 1995)
  kahan_li17    ///< order 8, 17 steps (Kahan & Li 1997)
};

/// The name of a composition, as the CLI spells it ("triple-jump", "suzuki-5", …).
inline const char* to_string(Composition c) {
  switch (c) {
    case Composition::base: return "base";
    case Composition::triple_jump: return "triple-jump";
    case Composition::suzuki5: return "suzuki-5";
    case Composition::kahan_li9: return "kahan-li-9";
    case Composition::mclachlan15: return "mclachlan-15";
    case Composition::kahan_li17: return "kahan-li-17";
  }
  return "unknown";
}

/// The default composition of each order: 2 → base, 4 → triple jump, 6 → Kahan–Li.
/// Throws invalid_input for any other order (the order-8 sets are chosen by name:
/// Composition::kahan_li17, Composition::mclachlan15).
inline Composition composition_of_order(int order) {
  switch (order) {
    case 2: return Composition::base;
    case 4: return Composition::triple_jump;
    case 6: return Composition::kahan_li9;
    default: detail::fail("composition: order must be 2, 4 or 6, got ", order);
  }
}

/// The weights γ_1 … γ_s of a symmetric composition of order 2, 4, 6 or 8.
template <class Scalar>
struct CompositionCoefficients {
  /// The largest number of sub-steps of the compositions on offer (Kahan–Li's 17).
  static constexpr int max_stages = 17;
  /// Which composition.
  Composition method = Composition::base;
  /// Its order: 2, 4, 6 or 8.
  int order = 2;
  /// The number of sub-steps s.
  int stages = 1;
  /// The weights γ_1 … γ_s (the rest are zero).
  std::array<Scalar, max_stages> gamma{};

  /// Throws invalid_input unless order is 2, 4 or 6 (composition_of_order).
  static CompositionCoefficients of_order(int order) { return of(composition_of_order(order)); }

  /// The weights of a named composition. Throws invalid_input for an unknown one.
  static CompositionCoefficients of(Composition method) {
    CompositionCoefficients c;
    c.method = method;
    switch (method) {
      case Composition::base:
        c.order = 2;
        c.stages = 1;
        c.gamma[0] = Scalar(1);
        break;
      case Composition::triple_jump: {
        // Triple jump (Creutz & Gocksch 1989, Forest 1989, Suzuki 1990, Yoshida 1990;
        // Hairer–Lubich–Wanner, Geometric Numerical Integration, 2nd ed., §II.4 (4.4)):
        //   γ1 = γ3 = 1/(2 − 2^{1/3}),  γ2 = −2^{1/3}/(2 − 2^{1/3}).
        // Written out in long double (rounded once to Scalar) rather than computed, so that
        // every Scalar gets the correctly rounded value.
        c.order = 4;
        c.stages = 3;
        c.gamma[0] = c.gamma[2] = Scalar(1.35120719195965763404768780897146083L);
        c.gamma[1] = Scalar(-1.70241438391931526809537561794292165L);
        break;
      }
      case Composition::suzuki5:
        // Suzuki, "Fractal decomposition of exponential operators", Phys. Lett. A 146
        // (1990) 319–323; Hairer–Lubich–Wanner, §II.4 (4.5), §V.3.2:
        //   γ1 = γ2 = γ4 = γ5 = 1/(4 − 4^{1/3}),  γ3 = −4^{1/3}/(4 − 4^{1/3}).
        c.order = 4;
        c.stages = 5;
        c.gamma[0] = c.gamma[1] = c.gamma[3] = c.gamma[4] = Scalar(0.41449077179437573714235406286076373L);
        c.gamma[2] = Scalar(-0.65796308717750294856941625144305492L);
        break;
      case Composition::kahan_li9:
        // Kahan & Li, "Composition constants for raising the orders of unconventional
        // schemes for ordinary differential equations", Math. Comp. 66 (1997) 1089–1099:
        // the s = 9 order-6 set, as printed in Hairer–Lubich–Wanner, Geometric Numerical
        // Integration, 2nd ed., §V.3.2, eq. (3.11). Its error constant is much smaller
        // than that of Yoshida's s = 7 set (ibid. (3.10)).
        c.order = 6;
        c.stages = 9;
        c.gamma[0] = c.gamma[8] = Scalar(0.39216144400731413927925056L);
        c.gamma[1] = c.gamma[7] = Scalar(0.33259913678935943859974864L);
        c.gamma[2] = c.gamma[6] = Scalar(-0.70624617255763935980996482L);
        c.gamma[3] = c.gamma[5] = Scalar(0.08221359629355080023149045L);
        c.gamma[4] = Scalar(0.79854399093482996339895035L);
        break;
      case Composition::mclachlan15: {
        // McLachlan, "On the numerical integration of ordinary differential equations by
        // symmetric composition methods", SIAM J. Sci. Comput. 16 (1995) 151–168: the
        // s = 15 order-8 set, as printed in Hairer–Lubich–Wanner, §V.3.2 ([P4]). Checked
        // in tests/test_composition.cpp: Σγ = 1, Σγ³ = Σγ⁵ = Σγ⁷ = 0, observed order 8.
        c.order = 8;
        c.stages = 15;
        const Scalar g[8] = {Scalar(0.74167036435061295344822780L), Scalar(-0.40910082580003159399730010L),
                             Scalar(0.19075471029623837995387626L), Scalar(-0.57386247111608226665638773L),
                             Scalar(0.29906418130365592384446354L), Scalar(0.33462491824529818378495798L),
                             Scalar(0.31529309239676659663205666L), Scalar(-0.79688793935291635401978884L)};
        for (int i = 0; i < 8; ++i) c.gamma[std::size_t(i)] = c.gamma[std::size_t(14 - i)] = g[i];
        break;
      }
      case Composition::kahan_li17: {
        // Kahan & Li (1997), as above: the s = 17 order-8 set (Hairer–Lubich–Wanner,
        // §V.3.2), whose error constant is smaller than McLachlan's s = 15 ([P4]).
        c.order = 8;
        c.stages = 17;
        const Scalar g[9] = {Scalar(0.13020248308889008087881763L), Scalar(0.56116298177510838456196441L),
                             Scalar(-0.38947496264484728640807860L), Scalar(0.15884190655515560089621075L),
                             Scalar(-0.39590389413323757733623154L), Scalar(0.18453964097831570709183254L),
                             Scalar(0.25837438768632204729397911L), Scalar(0.29501172360931029887096624L),
                             Scalar(-0.60550853383003451169892108L)};
        for (int i = 0; i < 9; ++i) c.gamma[std::size_t(i)] = c.gamma[std::size_t(16 - i)] = g[i];
        break;
      }
      default:
        detail::fail("composition: unknown method ", static_cast<int>(method));
    }
    return c;
  }
};

/// The weights of the processed method of Blanes, Casas & Murua, "Composition methods for
/// differential equations with processing", SIAM J. Sci. Comput. 27 (2006) 1817–1843: the
/// order-6 kernel of s = 13 symmetric stages and its processor of 12 stages ([P5]).
template <class Scalar>
struct ProcessedCoefficients {
  /// Kernel stages s.
  static constexpr int kernel_stages = 13;
  /// Processor stages.
  static constexpr int processor_stages = 12;
  /// The order of the processed outputs.
  static constexpr int order = 6;
  /// Kernel weights a_1 … a_13 (a_i = a_{14−i}, Σa_i = 1).
  std::array<Scalar, kernel_stages> kernel{};
  /// Processor weights p_1 … p_12 (Σp_j = 0): P_h = Φ_{p_1 h} ∘ … ∘ Φ_{p_12 h}, the step
  /// p_12 h first.
  std::array<Scalar, processor_stages> processor{};

  /// The published weights (to the 15 digits printed; the dependent ones computed here).
  static ProcessedCoefficients bcm13() {
    ProcessedCoefficients c;
    // Kernel: a1 = a2 = a3 = a4, a5, a6, then the centre from Σa_i = 1, mirrored.
    const long double a1 = 0.125696288720106L, a5 = 0.148070660114965L, a6 = -0.350856370823828L;
    const long double centre = 1.0L - 2.0L * (4.0L * a1 + a5 + a6);
    const long double half[7] = {a1, a1, a1, a1, a5, a6, centre};
    for (int i = 0; i < 7; ++i) c.kernel[std::size_t(i)] = c.kernel[std::size_t(12 - i)] = Scalar(half[i]);
    // Processor: g1 … g5 printed, g6 = −(g1 + … + g5), g_{6+j} = −g_j; p_j = −g_j.
    long double g[12] = {0.1L, 0.225080298761176L, 0.191244694511161L, -0.212763792194890L,
                         -0.09660157306582295L, 0.0L};
    g[5] = -(g[0] + g[1] + g[2] + g[3] + g[4]);
    for (int j = 0; j < 6; ++j) g[6 + j] = -g[j];
    for (int j = 0; j < 12; ++j) c.processor[std::size_t(j)] = Scalar(-g[j]);
    return c;
  }
};

}  // namespace trompo
