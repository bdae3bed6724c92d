// libFuzzer entry point (built by scripts/fuzz.sh with clang).
#include "fuzz_input.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size)
{
  constrained_particles::fuzz::runInput(data, size);
  return 0;
}
