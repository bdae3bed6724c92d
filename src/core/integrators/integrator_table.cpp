// The table of integrators (integrators.hpp): one row per file in this folder.
#include "constrained_particles/core/integrators.hpp"
#include "constrained_particles/core/types.hpp"

namespace constrained_particles
{
extern const IntegratorInfo EXPLICIT_EULER_INTEGRATOR;       // explicit_euler.cpp
extern const IntegratorInfo SEMI_IMPLICIT_EULER_INTEGRATOR;  // semi_implicit_euler.cpp
extern const IntegratorInfo MIDPOINT_INTEGRATOR;             // midpoint.cpp
extern const IntegratorInfo RK4_INTEGRATOR;                  // rk4.cpp
extern const IntegratorInfo VELOCITY_VERLET_INTEGRATOR;      // velocity_verlet.cpp
extern const IntegratorInfo DOPRI5_INTEGRATOR;               // dopri5.cpp
extern const IntegratorInfo FAST_PROJECTION_INTEGRATOR;      // fast_projection.cpp

const std::vector<const IntegratorInfo*>& integratorTable()
{
  static const std::vector<const IntegratorInfo*> TABLE = {
    &EXPLICIT_EULER_INTEGRATOR,  &SEMI_IMPLICIT_EULER_INTEGRATOR,
    &MIDPOINT_INTEGRATOR,        &RK4_INTEGRATOR,
    &VELOCITY_VERLET_INTEGRATOR, &DOPRI5_INTEGRATOR,
    &FAST_PROJECTION_INTEGRATOR,
  };
  return TABLE;
}

const IntegratorInfo& findIntegrator(const std::string& name, const std::string& field)
{
  for (const IntegratorInfo* integrator : integratorTable())
    if (name == integrator->name)
      return *integrator;
  std::string valid;
  for (const IntegratorInfo* integrator : integratorTable())
    valid += std::string(valid.empty() ? "" : ", ") + integrator->name;
  throw InvalidInput(field, "= '" + name + "' is unknown; valid: " + valid);
}

std::vector<std::string> integratorNames()
{
  std::vector<std::string> names;
  for (const IntegratorInfo* integrator : integratorTable())
    names.push_back(integrator->name);
  return names;
}

}  // namespace constrained_particles
