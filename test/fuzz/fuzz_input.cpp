#include "fuzz_input.hpp"

#include "constrained_particles/core/simulator.hpp"
#include "constrained_particles/scenes/scene_file.hpp"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <string>
#include <vector>

namespace constrained_particles
{
namespace fuzz
{
namespace
{
// the node's default limit: larger scenes are refused there before they are built
constexpr long MAX_FUZZ_PARTICLES = 2000;
// particles x sub-steps per step: a whipping chain of 350 at dt = 1 s split 1,024 ways took
// over libFuzzer's 10 s under ASan (scripts/fuzz.sh; test/fuzz/regressions)
constexpr long MAX_FUZZ_WORK = 16384;

[[noreturn]] void finding(const char* what)
{
  std::fprintf(stderr, "fuzz finding: %s\n", what);
  std::abort();
}

std::vector<double> doubles(const std::uint8_t* data, std::size_t size)
{
  std::vector<double> values(size / sizeof(double));
  if (!values.empty())
    std::memcpy(values.data(), data, values.size() * sizeof(double));
  return values;
}

void runScene(const std::string& text)
{
  const SceneDescription d = parseScene(text, "fuzz.yaml");
  if (d.numParticles() > MAX_FUZZ_PARTICLES)
    return;
  const BuiltScene s = buildScene(d);
  StepSettings settings = d.solver.applyTo(StepSettings{});
  // crashes and sanitizer reports are the hunt, not slow steps: particles x sub-steps bounded
  settings.max_substeps = std::min(
      settings.max_substeps,
      static_cast<int>(std::max<long>(16, MAX_FUZZ_WORK / std::max<long>(1, d.numParticles()))));
  Simulator simulator(s.scene, s.initial_state, settings, d.solver.solve_method);
  if (!isFinite(simulator.state()))
    finding("an accepted scene starts non-finite");
  simulator.step(3);
  (void)simulator.diagnostics();
}

void runFormula(const std::string& text)
{
  const Surface surface = makeExpressionSurface(text, "expression");
  for (double x : { -1.0, 0.0, 0.5, 3.0 })
    (void)evaluateSurface(surface, x, 0.7 * x);
}

Simulator surfaceChain()
{
  const SceneDescription d = parseScene(
      "surfaces: {ground: {type: bowl}}\n"
      "chains: [{particles: 3, start: [0.5, 0, 0], direction: [0.5, 0, -0.87], surface: ground}]\n"
      "forces: [{type: gravity}]\n",
      "fuzz.yaml");
  const BuiltScene s = buildScene(d);
  return Simulator(s.scene, s.initial_state, StepSettings{});
}

void runState(const std::uint8_t* data, std::size_t size)
{
  Simulator simulator = surfaceChain();
  const std::vector<double> values = doubles(data, size);
  const int n = simulator.model().numParticles();
  State state = simulator.state();
  const int given = static_cast<int>(values.size() / 3);
  state.positions.resize(3, std::min(given, n + 1));
  state.velocities.setZero(3, state.positions.cols());
  for (int i = 0; i < state.positions.cols(); ++i)
    for (int axis = 0; axis < 3; ++axis)
      state.positions(axis, i) = values[3 * i + axis];
  simulator.setState(state);  // throws if malformed or off the manifold beyond repair
  if (!isFinite(simulator.state()))
    finding("an accepted state is non-finite");
  simulator.step(2);
}

void runChainAndSurface(const std::uint8_t* data, std::size_t size)
{
  const std::vector<double> values = doubles(data, size);
  // the count and the surface type are picked from two values: they must be numbers
  if (values.size() < 4 || !std::isfinite(values[0]) || !std::isfinite(values[3]))
    return;
  SceneDescription d = parseScene(
      "surfaces: {ground: {type: bowl}}\n"
      "chains: [{particles: 3, start: [0.5, 0, 0], direction: [0.5, 0, -0.87], surface: ground}]\n",
      "fuzz.yaml");
  ChainChange chain;
  chain.num_particles = static_cast<int>(std::fmod(std::abs(values[0]), 50.0)) + 1;
  chain.link_length = values[1];
  chain.particle_mass = values[2];
  if (!limits::LINK_LENGTH.contains(chain.link_length) ||
      !limits::MASS.contains(chain.particle_mass))
    return;  // the node's validateChainChange refuses these before the scene is touched
  setChains(d, chain);
  const std::vector<double> coefficients(values.begin() + 3,
                                         values.begin() + std::min<std::size_t>(values.size(), 8));
  const SurfaceType type = static_cast<SurfaceType>(std::fmod(std::abs(values[3]), 5.0));
  setFirstSurface(d, makeSurface(type, coefficients, "coefficients"));
  const BuiltScene s = buildScene(d);
  Simulator simulator(s.scene, s.initial_state, StepSettings{});
  simulator.step(3);
}

}  // namespace

void runInput(const std::uint8_t* data, std::size_t size)
{
  if (size == 0)
    return;
  const std::uint8_t mode = data[0] % 4;
  const std::string text(reinterpret_cast<const char*>(data + 1), size - 1);
  try
  {
    switch (mode)
    {
      case 0:
        runScene(text);
        break;
      case 1:
        runFormula(text);
        break;
      case 2:
        runState(data + 1, size - 1);
        break;
      default:
        runChainAndSurface(data + 1, size - 1);
        break;
    }
  }
  catch (const InvalidInput&)
  {
    // refused: what bad input should get
  }
}

}  // namespace fuzz
}  // namespace constrained_particles
