// A steady-state step touches no heap on the single-row, tridiagonal and tree paths, with every
// integrator and stabilisation; the sparse path allocates only what Eigen's factorisation needs,
// the same number every step. Counted by interposing malloc (sanitizer builds: their hooks).
#include "constrained_particles/core/integrators.hpp"
#include "constrained_particles/core/simulator.hpp"
#include "test_helpers.hpp"

#include "fixed_point.hpp"

#include <gtest/gtest.h>

#include <atomic>
#include <cstddef>
#include <cerrno>
#include <cmath>
#include <cstdlib>

namespace
{
std::atomic<bool> counting{ false };
std::atomic<long> allocations{ 0 };

void noteAllocation()
{
  if (counting.load(std::memory_order_relaxed))
    allocations.fetch_add(1, std::memory_order_relaxed);
}

}  // namespace

#if defined(__SANITIZE_ADDRESS__) || defined(__SANITIZE_THREAD__)
// the sanitizers own malloc: count through the hooks they offer (declared in clang's
// sanitizer/allocator_interface.h, which GCC does not ship; its runtimes define it all the same)
extern "C" int __sanitizer_install_malloc_and_free_hooks(void (*malloc_hook)(const volatile void*,
                                                                             std::size_t),
                                                         void (*free_hook)(const volatile void*));

namespace
{
void onMalloc(const volatile void* /*pointer*/, std::size_t /*size*/)
{
  noteAllocation();
}
void onFree(const volatile void* /*pointer*/)
{
}
const int HOOKS_INSTALLED = __sanitizer_install_malloc_and_free_hooks(onMalloc, onFree);

}  // namespace
#else
// glibc's own allocator under its internal names: every malloc of the process (operator new,
// Eigen, Boost) comes through these
extern "C"
{
  void* __libc_malloc(std::size_t size);
  void* __libc_calloc(std::size_t count, std::size_t size);
  void* __libc_realloc(void* pointer, std::size_t size);
  void* __libc_memalign(std::size_t alignment, std::size_t size);

  void* malloc(std::size_t size)
  {
    noteAllocation();
    return __libc_malloc(size);
  }
  void* calloc(std::size_t count, std::size_t size)
  {
    noteAllocation();
    return __libc_calloc(count, size);
  }
  void* realloc(void* pointer, std::size_t size)
  {
    noteAllocation();
    return __libc_realloc(pointer, size);
  }
  void* memalign(std::size_t alignment, std::size_t size)
  {
    noteAllocation();
    return __libc_memalign(alignment, size);
  }
  void* aligned_alloc(std::size_t alignment, std::size_t size)
  {
    noteAllocation();
    return __libc_memalign(alignment, size);
  }
  int posix_memalign(void** pointer, std::size_t alignment, std::size_t size)
  {
    noteAllocation();
    *pointer = __libc_memalign(alignment, size);
    return *pointer ? 0 : ENOMEM;
  }
}
namespace
{
const int HOOKS_INSTALLED = 1;
}
#endif

using namespace constrained_particles;
using constrained_particles::testing::shippedScene;

namespace
{
// heap allocations made by fn
template <typename Fn>
long allocationsIn(Fn fn)
{
  allocations = 0;
  counting = true;
  fn();
  counting = false;
  return allocations.load();
}

StepSettings settingsOf(const std::string& integrator, Stabilization stabilization)
{
  StepSettings settings;
  settings.integrator = integrator;
  settings.stabilization = stabilization;
  settings.dt = 1e-3;
  return settings;
}

// a random tree whose every particle hangs from an earlier one, with two rows (a wire) inside
// some particles' blocks: the tree solve's multi-row path
BuiltScene treeWithWires()
{
  constrained_particles::testing::Random random(77);
  BuiltScene s;
  const int n = 30;
  s.initial_state.positions.resize(3, n);
  s.initial_state.velocities.setZero(3, n);
  s.initial_state.positions.col(0).setZero();
  s.scene.masses.assign(n, 0.2);
  for (int k = 1; k < n; ++k)
  {
    const int parent = static_cast<int>(random.uniform(0.0, k - 1e-9));
    s.initial_state.positions.col(k) =
        s.initial_state.positions.col(parent) + 0.3 * random.unitVector();
    s.scene.constraints.push_back(LinkConstraint{ parent, k, 0.3 });
  }
  for (int k = 3; k < n; k += 9)
    s.scene.constraints.push_back(
        PointOnLineConstraint{ k, Vec3(s.initial_state.positions.col(k)), Vec3(1.0, 0.2, 0.1) });
  s.scene.constraints.push_back(PinConstraint{ 0, Vec3::Zero() });
  s.scene.forces = { GravityForce{} };
  return s;
}

// Six particles linked to a seventh, the hub, hanging from a pin: seven rows on the hub, so the
// tree solve eliminates particles (tree.cpp) rather than rows.
BuiltScene starOfSix()
{
  BuiltScene s;
  s.scene.masses.assign(8, 0.3);
  s.initial_state.positions.setZero(3, 8);
  s.initial_state.velocities.setZero(3, 8);
  s.initial_state.positions.col(0) = Vec3(0.0, 0.0, 0.5);
  s.scene.constraints.push_back(LinkConstraint{ 0, 1, 0.5 });
  for (int k = 2; k < 8; ++k)
  {
    const double angle = 2.0 * M_PI * k / 6.0;
    s.initial_state.positions.col(k) = Vec3(0.4 * std::cos(angle), 0.4 * std::sin(angle), -0.3);
    s.scene.constraints.push_back(LinkConstraint{ 1, k, 0.5 });
  }
  s.scene.constraints.push_back(PinConstraint{ 0, Vec3(0.0, 0.0, 0.5) });
  s.scene.forces = { GravityForce{} };
  return s;
}

}  // namespace

TEST(Allocations, TheCounterSeesAllocations)
{
  ASSERT_EQ(HOOKS_INSTALLED, 1);
  EXPECT_GT(allocationsIn(
                []
                {
                  Eigen::VectorXd v(1000);
                  v.setZero();
                }),
            0);
  EXPECT_GT(allocationsIn(
                []
                {
                  std::vector<int> v(10);
                  v[0] = 1;
                }),
            0);
  EXPECT_EQ(allocationsIn([] {}), 0);
}

// a particle on a wire across the link to the particle below it: the tree is rooted at the
// particle with rows of its own, so the elimination needs no fallback
BuiltScene wireAcrossItsLink()
{
  BuiltScene built;
  built.scene.masses = { 0.5, 0.8 };
  built.scene.forces = { GravityForce{} };
  built.scene.constraints = {
    PointOnLineConstraint{ 1, Vec3(0.0, 0.0, 1.0), Vec3(1.0, 0.0, 0.0) },
    LinkConstraint{ 0, 1, 0.5 },
  };
  built.initial_state.positions.resize(3, 2);
  built.initial_state.positions << 0.02, 0.0, 0.0, 0.0, 0.5, 1.0;  // 0.04 rad from vertical
  built.initial_state.velocities = Points::Zero(3, 2);
  return built;
}

// the same with the lower particle held on a plane: two particles of one tree with rows of their
// own, so one is below the root, and its wire locks it along the link: the tree elimination
// breaks down and the sparse fallback (made when the model is compiled) solves it
BuiltScene twoHeldAcrossTheirLink()
{
  BuiltScene built = wireAcrossItsLink();
  built.scene.constraints.push_back(
      PointOnPlaneConstraint{ 0, Vec3(0.02, 0.0, 0.5), Vec3(0.0, 1.0, 0.0) });
  return built;
}

// single row (bead), tridiagonal (chain, surface chain, driven chain) and tree (mobile, a bead on
// a wire, random trees with two-row blocks), also pushed and pulled from outside
// (perturbations): nothing after warm-up, whatever the method
TEST(Allocations, SteadyStepsAllocateNothingOnTheLinearTimePaths)
{
  std::vector<std::pair<std::string, BuiltScene>> scenes;
  for (const char* name : { "bead", "chain", "surface_chain", "shaken_chain", "mobile",
                            "bead_on_wire", "sled_on_ramp" })
    scenes.emplace_back(name, shippedScene(name));
  scenes.emplace_back("tree with wires", treeWithWires());
  scenes.emplace_back("wire across its link", wireAcrossItsLink());
  scenes.emplace_back("star of six", starOfSix());
  int checked = 0;
  // every tree path is covered: the fused stages (Model::fusedTree()), the generic stages with the
  // solve by rows (Model::solvesTreeByRows()), and with the solve by particles
  int fused = 0, by_rows = 0, by_particles = 0;
  for (const auto& [name, built] : scenes)
    for (const IntegratorInfo* integrator : integratorTable())
      for (Stabilization stabilization :
           { Stabilization::None, Stabilization::Baumgarte, Stabilization::Projection })
      {
        Simulator simulator(built.scene, built.initial_state,
                            settingsOf(integrator->name, stabilization));
        const SolveMethod method = simulator.model().solveMethod();
        if (method == SolveMethod::Tree)
          (simulator.model().fusedTree()          ? fused
           : simulator.model().solvesTreeByRows() ? by_rows
                                                  : by_particles) += 1;
        ASSERT_TRUE(method == SolveMethod::Single || method == SolveMethod::Tridiagonal ||
                    method == SolveMethod::Tree)
            << name;
        simulator.step(100);  // warm-up: dopri5 makes its workspace on its first step
        StepStatistics statistics;
        const long count = allocationsIn([&] { statistics = simulator.step(100); });
        // a tree solve handed to the sparse fallback would allocate: none of these needs it
        EXPECT_EQ(statistics.solve.fallbacks, 0) << name;
        EXPECT_EQ(count, 0) << name << ", " << integrator->name << " + "
                            << stabilizationName(stabilization) << ", " << solveMethodName(method);
        EXPECT_EQ(allocationsIn([&] { (void)simulator.diagnostics(); }), 0) << name;
        // pushed and pulled from outside the model (the node's ~apply_force and drag), gently,
        // over the same steps: the path is what is checked, not a new motion (later steps fold
        // the random trees into the tree solve's sparse fallback, which allocates by design)
        Simulator pushed(built.scene, built.initial_state,
                         settingsOf(integrator->name, stabilization));
        const int last = pushed.model().numParticles() - 1;
        pushed.setPerturbations(
            { ExternalForce{ last, Vec3(1e-6, 0.0, 0.0) },
              TargetSpringForce{ last, Vec3(pushed.state().positions.col(last)), 1e-6, 1e-6 } });
        pushed.step(100);
        EXPECT_EQ(allocationsIn([&] { statistics = pushed.step(100); }), 0)
            << name << " perturbed, " << integrator->name << " + "
            << stabilizationName(stabilization);
        EXPECT_EQ(statistics.solve.fallbacks, 0) << name << " perturbed";
        ++checked;
      }
  EXPECT_EQ(checked, 10 * static_cast<int>(integratorTable().size()) * 3);
  EXPECT_GT(fused, 0);
  EXPECT_GT(by_rows, 0);
  EXPECT_GT(by_particles, 0);
}

// The friction iteration's Anderson mixing (fixed_point.hpp), once its history and vectors have
// their sizes (Data's), touches no heap: its normal equations are fixed-size, and a mixed step,
// a plain one and a cleared history's first all run in place
TEST(Allocations, AndersonMixingAllocatesNothing)
{
  const int dimension = 30;
  FixedPointHistory history;
  resizeHistory(history, dimension, 5);
  Eigen::VectorXd x = Eigen::VectorXd::Zero(dimension), g(dimension), next(dimension);
  long mixed = 0;
  const long count = allocationsIn(
      [&]
      {
        for (int k = 0; k < 12; ++k)
        {
          if (k == 8)
            clearHistory(history);
          for (int i = 0; i < dimension; ++i)
            g[i] = 0.9 * x[(i + 1) % dimension] + 1.0 / (1.0 + i);
          andersonStep(history, x, g, next);
          mixed += next != g;
          x.swap(next);
        }
      });
  EXPECT_EQ(count, 0);
  EXPECT_GE(mixed, 8);  // the steps after each history's first were mixed, not plain
}

// the sparse path (cycles: a zig-zag of links and angles), and the tree's sparse fallback, keep
// Eigen's factorisation, whose allocations per factorisation are fixed: the count per 100 steps
// does not grow
TEST(Allocations, SparseStepsAllocateTheSameEveryStep)
{
  const std::pair<const char*, BuiltScene> scenes[] = {
    { "zigzag_chain", shippedScene("zigzag_chain") },
    { "two held across their link", twoHeldAcrossTheirLink() }
  };
  for (const auto& [name, built] : scenes)
    for (const IntegratorInfo* integrator : integratorTable())
    {
      const bool fallback = std::string(name) != "zigzag_chain";
      // the fallback is the particle elimination's (tree.cpp), which the generic paths keep; the
      // row elimination (Model::solvesTreeByRows()) needs none
      Simulator simulator(
          built.scene, built.initial_state, settingsOf(integrator->name, Stabilization::Projection),
          SolveMethod::Automatic, fallback ? StagePaths::Generic : StagePaths::Specialized);
      ASSERT_EQ(simulator.model().solveMethod(), fallback ? SolveMethod::Tree : SolveMethod::Sparse)
          << name;
      simulator.step(100);
      long counts[3];
      long factorizations[3];
      for (int k = 0; k < 3; ++k)
      {
        StepStatistics statistics;
        counts[k] = allocationsIn([&] { statistics = simulator.step(100); });
        factorizations[k] = statistics.solve.factorizations;
        if (fallback)  // every factorisation of this swing is the fallback's
        {
          EXPECT_EQ(statistics.solve.fallbacks, statistics.solve.factorizations) << name;
        }
      }
      // the same work each batch allocates the same; dopri5's internal steps may differ
      for (int k = 1; k < 3; ++k)
      {
        EXPECT_LE(counts[k] * factorizations[0], counts[0] * factorizations[k])
            << name << ", " << integrator->name << ": " << counts[0] << ", " << counts[k]
            << " allocations for " << factorizations[0] << ", " << factorizations[k]
            << " factorisations";
      }
      EXPECT_GT(counts[0], 0) << "the sparse factorisation allocates: the counter must see it";
    }
}
