// One fuzz input through the core and the scene loader: shared by the libFuzzer target
// (scripts/fuzz.sh) and the regression gtest that replays test/fuzz/regressions/.
#pragma once

#include <cstddef>
#include <cstdint>

namespace constrained_particles
{
namespace fuzz
{
/// The first byte picks what the rest is: 0 a scene file, 1 a surface formula, 2 a ~set_state
/// payload (doubles) for the surface_chain scene, 3 ~set_chain and ~set_surface values. Bad input
/// must be refused with InvalidInput; anything else (a crash, a sanitizer report, another
/// exception, a non-finite value from an accepted request) is a finding.
void runInput(const std::uint8_t* data, std::size_t size);

}  // namespace fuzz
}  // namespace constrained_particles
