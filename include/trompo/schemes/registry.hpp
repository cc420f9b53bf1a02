#pragma once
// The scheme registry: the one list from which every tool takes its schemes: the CLI
// and the Python module (tools/simulate), trompo-invariants, the bench, the fuzzer and
// the generic property tests (tests/test_properties_*.cpp). Adding a scheme to all of
// them is one line in `RegisteredSchemes` below (plus, for a scheme with parameters, its
// CLI flags in tools/simulate).
//
// An entry, Registered<Scheme, compositions, scenes>, gives the type (its name, order,
// symmetry and kept invariants are the scheme's own traits, scheme.hpp) and what the tools
// need beyond them:
//   compositions  how the tools compose it: `symmetric` (ComposedStepper with a named
//                 composition or an order, ProcessedStepper; wherever the scheme is
//                 symmetric with its parameters), `own` (its own composition methods:
//                 splitting's --composition strang|chin-4a|…) or `none` (run plain only);
//   scenes        which scenes it steps: `all`; `conservative` (no applied torque or
//                 damping: potentials and rotors); `heavy_top` (conservative, and its
//                 potentials linear in the attitude: the free body and the heavy top under
//                 uniform gravity); or `free_body`.
// A scheme that cannot step a scene at all (another Scalar, say) is left out there by
// SchemeFor; Registered::steps<Scene> says both.
//
// A test build may append schemes with the compile definitions TROMPO_EXTRA_SCHEMES_HEADER
// (a header to include) and TROMPO_EXTRA_SCHEMES (entries, each preceded by a comma):
// tests/CMakeLists.txt builds the generic tests so with the scheme of examples/own_scheme.hpp
// (and, with TROMPO_CHECK_OWN_SCHEME, the CLI), and checks it appears with no other edit.
#include <cstddef>
#include <tuple>
#include <string_view>
#include <type_traits>

#include "trompo/schemes/explicit/rk4.hpp"
#include "trompo/schemes/families/constrained_trapezoid.hpp"
#include "trompo/schemes/families/energy_decaying.hpp"
#include "trompo/schemes/families/lie_gen_alpha.hpp"
#include "trompo/schemes/geradin_bauchau/geradin_bauchau.hpp"
#include "trompo/schemes/geradin_bauchau/geradin_bauchau_paper.hpp"
#include "trompo/schemes/lie_rk/crouch_grossman.hpp"
#include "trompo/schemes/lie_rk/rkmk4.hpp"
#include "trompo/schemes/scheme.hpp"
#include "trompo/schemes/simo/simo.hpp"
#include "trompo/schemes/splitting/splitting.hpp"
#include "trompo/schemes/variational/dmv.hpp"
#include "trompo/schemes/variational/lgvi.hpp"
#ifdef TROMPO_EXTRA_SCHEMES_HEADER
#include TROMPO_EXTRA_SCHEMES_HEADER
#endif
#ifndef TROMPO_EXTRA_SCHEMES
#define TROMPO_EXTRA_SCHEMES
#endif

namespace trompo {

/// How the tools compose a registered scheme (see the file comment).
enum class Compositions { symmetric, own, none };

/// Which scenes a registered scheme steps (see the file comment).
enum class Scenes { all, conservative, heavy_top, free_body };

/// One registry entry: a scheme type and what the tools need to know about it.
template <class Scheme_, Compositions Compositions_ = Scheme_::traits.symmetric ? Compositions::symmetric : Compositions::none,
          Scenes Scenes_ = Scenes::all>
struct Registered {
  /// The scheme type.
  using Scheme = Scheme_;
  /// Its name, as --scheme, the reports and the test names spell it.
  static constexpr const char* name = Scheme::name;
  /// How the tools compose it.
  static constexpr Compositions compositions = Compositions_;
  /// Which scenes it steps.
  static constexpr Scenes scenes = Scenes_;
  /// Whether it steps Scene (a SchemeFor model, and the scene is one it accepts).
  template <class Scene>
  static constexpr bool steps =
      SchemeFor<Scheme, Scene> &&
      (Scenes_ == Scenes::all || (Scenes_ == Scenes::conservative && !Scene::has_applied_torque) ||
       (Scenes_ == Scenes::heavy_top && !Scene::has_applied_torque && Scene::potentials_linear) ||
       (Scenes_ == Scenes::free_body && Scene::is_free));
};

/// A list of registry entries.
template <class... Entries>
struct SchemeList {
  /// The number of entries.
  static constexpr std::size_t size = sizeof...(Entries);
  /// Calls f(std::type_identity<Entry>{}) for every entry, in order.
  template <class F>
  static constexpr void for_each(F&& f) {
    (f(std::type_identity<Entries>{}), ...);
  }
  /// Calls f(std::type_identity<Entry>{}) for the entry named `name` and returns true,
  /// or returns false if none is.
  template <class F>
  static constexpr bool visit(std::string_view name, F&& f) {
    return ((name == Entries::name ? (f(std::type_identity<Entries>{}), true) : false) || ...);
  }
  /// Whether some entry is named `name`.
  static constexpr bool contains(std::string_view name) { return ((name == Entries::name) || ...); }
  /// The scheme types alone, as a std::tuple (Catch2's TEMPLATE_LIST_TEST_CASE takes one).
  using Schemes = std::tuple<typename Entries::Scheme...>;
  /// The entries as a std::tuple.
  using Tuple = std::tuple<Entries...>;
};

// clang-format off
/// Every scheme of the library, one line each.
using RegisteredSchemes = SchemeList<
    Registered<SimoAlpha>,
    Registered<SimoCollocation>,
    Registered<SimoKappa>,
    Registered<GeradinBauchau>,
    Registered<GeradinBauchauPaper>,
    Registered<RK4>,
    Registered<Splitting, Compositions::own>,
    Registered<LieGenAlpha>,
    Registered<ConstrainedTrapezoid, Compositions::none, Scenes::conservative>,
    Registered<EnergyDecaying, Compositions::none, Scenes::heavy_top>,
    Registered<LGVI>,
    Registered<DMV, Compositions::symmetric, Scenes::free_body>,
    Registered<RKMK4>,
    Registered<CrouchGrossman3>
    TROMPO_EXTRA_SCHEMES>;
// clang-format on

}  // namespace trompo
