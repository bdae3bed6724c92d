#include "constrained_particles/core/settings.hpp"

#include "constrained_particles/core/integrators.hpp"

#include <iterator>

namespace constrained_particles
{
namespace
{
const char* const STABILIZATION_NAMES[] = { "none", "baumgarte", "projection" };
}

const char* stabilizationName(Stabilization stabilization)
{
  const int index = static_cast<int>(stabilization);
  return index >= 0 && index < static_cast<int>(std::size(STABILIZATION_NAMES))
             ? STABILIZATION_NAMES[index]
             : "(invalid)";
}

std::vector<std::string> stabilizationNames()
{
  return { std::begin(STABILIZATION_NAMES), std::end(STABILIZATION_NAMES) };
}

Stabilization parseStabilization(const std::string& name, const std::string& field)
{
  const std::vector<std::string> names = stabilizationNames();
  for (std::size_t i = 0; i < names.size(); ++i)
    if (name == names[i])
      return static_cast<Stabilization>(i);
  std::string valid;
  for (const std::string& known : names)
    valid += (valid.empty() ? "" : ", ") + known;
  throw InvalidInput(field, "= '" + name + "' is unknown; valid: " + valid);
}

void validateStepSettings(const StepSettings& settings)
{
  forEachField<StepSettings>(
      [&](const auto& spec)
      {
        const auto& value = settings.*(spec.member);
        using Member = std::decay_t<decltype(value)>;
        if constexpr (std::is_same_v<Member, std::string>)
          findIntegrator(value, spec.name);
        else if constexpr (std::is_same_v<Member, Stabilization>)
          parseStabilization(stabilizationName(value), spec.name);  // "(invalid)" is refused
        else
          requireInRange(spec.name, static_cast<double>(value), *spec.range);
      });
}

}  // namespace constrained_particles
