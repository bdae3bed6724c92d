/// @file integrators.hpp
/// @brief The table of time integrators: name, order, whether it holds the constraints itself,
/// whether it adapts its step, and its step function. Names, parsing, the dynamic_reconfigure
/// enum (cfg/Simulator.cfg reads the rows when it is generated), the benchmark's theoretical
/// orders and the order tests read it. Each integrator is one file in src/core/integrators/;
/// adding one is that file plus its row in integrator_table.cpp.
#pragma once

#include <string>
#include <vector>

namespace constrained_particles
{
class Model;
class Data;
struct StepSettings;

/// Advances data.state's positions and velocities from data.state.time by settings.dt (the
/// caller then imposes eliminated motion, projects if asked, and advances time and steps).
using IntegratorStep = void (*)(const Model& model, Data& data, const StepSettings& settings);

/// dopri5's guards: more accepted and rejected internal steps than this in one dt, or an internal
/// step shorter than DOPRI5_MIN_INTERNAL_STEP dt, and the rest of the dt is taken as one
/// unchecked step (StepStatistics::forced_internal_steps), so a step ends in bounded work.
constexpr long DOPRI5_MAX_INTERNAL_STEPS = 100000;
constexpr double DOPRI5_MIN_INTERNAL_STEP = 1e-12;
/// No stability bound (IntegratorInfo::stability_limit).
constexpr double UNBOUNDED_STABILITY = 1e300;

/// One row of the table.
struct IntegratorInfo
{
  const char* name;        ///< as in parameters, scene files and dynamic_reconfigure
  int order;               ///< global order of accuracy in dt
  bool holds_constraints;  ///< projects onto the constraints itself: `stabilization` is ignored
  bool adaptive;           ///< chooses its own internal steps within dt (adaptive_tolerance)
  /// Largest omega dt [rad] at which an undamped oscillation of frequency omega stays bounded
  /// (the method's stability interval on the imaginary axis: RK4 2 sqrt(2), leapfrog 2;
  /// Hairer & Wanner, Solving ODEs II, IV.2), or for the methods unstable on that axis the omega
  /// dt that keeps growth per step under 0.5 %; infinity: no bound (implicit, or adapts itself).
  /// The stability estimate keeps omega_max dt_sub under STABILITY_SAFETY times it.
  double stability_limit;
  const char* description;  ///< one line, for help texts and dynamic_reconfigure
  IntegratorStep step;      ///< the step function
};

/// Every integrator, in the order they are documented.
const std::vector<const IntegratorInfo*>& integratorTable();

/// The integrator called `name`. @throws InvalidInput naming `field` and the valid names
const IntegratorInfo& findIntegrator(const std::string& name,
                                     const std::string& field = "integrator");

/// Every integrator's name, in table order.
std::vector<std::string> integratorNames();

}  // namespace constrained_particles
