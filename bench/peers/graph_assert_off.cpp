// LD_PRELOAD shim for Debian's Siconos 4.4 (python3-siconos): Debian builds Siconos
// without NDEBUG, so every edit of the kernel's interaction/dynamical-system graphs runs
// SiconosGraph::state_assert() and SiconosGraph::adjacent_vertices_ok() inside assert().
// Both are O(V + E) consistency walks, which makes each time step O(bodies x contacts).
// They are const checks with no side effect; a release build (NDEBUG) never calls them.
//
// This file defines the two member functions for the two graph types that
// libsiconos_kernel instantiates, each returning true.  Loaded first (LD_PRELOAD), these
// definitions win over the library's weak ones, which is what building Siconos with
// NDEBUG would give for these two checks.  Only the class template's name, parameter
// list and member signatures are declared here (enough for the linker names to match);
// nothing of Siconos is included.  bench/peers/run.sh compiles it with g++ at run time
// and checks with nm that the symbols match the installed library's.
#include <memory>

class Interaction;
class DynamicalSystem;
class InteractionProperties;
class DynamicalSystemProperties;
class GraphProperties;

template <class V, class E, class VProperties, class EProperties, class GProperties>
class SiconosGraph {
 public:
  bool state_assert() const;
  bool adjacent_vertices_ok() const;
};

template <class V, class E, class VP, class EP, class GP>
bool SiconosGraph<V, E, VP, EP, GP>::state_assert() const { return true; }

template <class V, class E, class VP, class EP, class GP>
bool SiconosGraph<V, E, VP, EP, GP>::adjacent_vertices_ok() const { return true; }

// DynamicalSystemsGraph and InteractionsGraph of the Siconos kernel.
template class SiconosGraph<std::shared_ptr<DynamicalSystem>, std::shared_ptr<Interaction>,
                            DynamicalSystemProperties, InteractionProperties, GraphProperties>;
template class SiconosGraph<std::shared_ptr<Interaction>, std::shared_ptr<DynamicalSystem>,
                            InteractionProperties, DynamicalSystemProperties, GraphProperties>;
