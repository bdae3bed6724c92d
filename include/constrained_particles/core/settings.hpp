/// @file settings.hpp
/// @brief How to take a step (StepSettings), described field by field like the effects, so the
/// core, scene files, the node's parameters and dynamic_reconfigure validate them alike.
#pragma once

#include "constrained_particles/core/effect_fields.hpp"
#include "constrained_particles/core/limits.hpp"

#include <string>
#include <tuple>
#include <vector>

namespace constrained_particles
{
/// Constraint drift correction (stabilization.cpp).
enum class Stabilization
{
  None,        ///< Cddot = 0 only: C drifts
  Baumgarte,   ///< Cddot + 2 zeta omega Cdot + omega^2 C = 0
  Projection,  ///< after each step: Newton projection of p onto C = 0, then of v onto J v = 0
};

/// "none", "baumgarte", "projection".
const char* stabilizationName(Stabilization stabilization);
/// Every stabilisation name, in enum order.
std::vector<std::string> stabilizationNames();
/// @throws InvalidInput naming field and the valid names
Stabilization parseStabilization(const std::string& name,
                                 const std::string& field = "stabilization");

/// How to take one step. Defaults are a good general choice; every field's range is in
/// limits.hpp and listed by fields().
struct StepSettings
{
  double dt = 1e-3;                                         ///< time step [s]
  std::string integrator = "rk4";                           ///< a name of integratorTable()
  Stabilization stabilization = Stabilization::Projection;  ///< drift correction
  double baumgarte_frequency = 10.0;                        ///< f [Hz], omega = 2 pi f
  double baumgarte_damping_ratio = 1.0;                     ///< zeta [1]
  double projection_tolerance = 1e-10;  ///< max position error after projection [m]
  int projection_max_iterations = 20;   ///< Newton iterations per projection
  double adaptive_tolerance = 1e-8;     ///< dopri5 absolute and relative tolerance [1]
  /// Most sub-steps of dt/2^k a step is split into when its checks fail or the stability
  /// estimate asks for them (simulator.hpp); 1 = never split [1]
  int max_substeps = 1024;
  /// Largest energy residual a run may gain, as a fraction of EnergyLedger::budgetScale(): a
  /// step that would overdraw it is retaken by the stiff-safe method, which keeps the run
  /// (simulator.hpp); 0 = not checked [1]
  double energy_budget = 1e-2;

  /// Every field: name (as in parameters and scene files), member, kind and range.
  static constexpr auto fields()
  {
    return std::make_tuple(
        field("dt", &StepSettings::dt, FieldKind::Number, &limits::DT, "physics time step"),
        field("integrator", &StepSettings::integrator, FieldKind::Name, nullptr,
              "time integrator (integratorTable())"),
        field("stabilization", &StepSettings::stabilization, FieldKind::Name, nullptr,
              "constraint drift correction"),
        field("baumgarte_frequency", &StepSettings::baumgarte_frequency, FieldKind::Number,
              &limits::BAUMGARTE_FREQUENCY, "Baumgarte frequency f, omega = 2 pi f"),
        field("baumgarte_damping_ratio", &StepSettings::baumgarte_damping_ratio, FieldKind::Number,
              &limits::BAUMGARTE_DAMPING_RATIO, "Baumgarte damping ratio"),
        field("projection_tolerance", &StepSettings::projection_tolerance, FieldKind::Number,
              &limits::PROJECTION_TOLERANCE, "max position error left by projection"),
        field("projection_max_iterations", &StepSettings::projection_max_iterations,
              FieldKind::Number, &limits::PROJECTION_MAX_ITERATIONS,
              "Newton iterations per projection"),
        field("adaptive_tolerance", &StepSettings::adaptive_tolerance, FieldKind::Number,
              &limits::ADAPTIVE_TOLERANCE, "dopri5 error per internal step"),
        field("max_substeps", &StepSettings::max_substeps, FieldKind::Number, &limits::MAX_SUBSTEPS,
              "most sub-steps a step is split into, 1 = never"),
        field("energy_budget", &StepSettings::energy_budget, FieldKind::Number,
              &limits::ENERGY_BUDGET, "largest energy residual over a run, of the scene's scale"));
  }
};

/// @throws InvalidInput naming the first bad field (as fields() names it) and its valid range
void validateStepSettings(const StepSettings& settings);

/// Every field of fields() equal.
inline bool operator==(const StepSettings& a, const StepSettings& b)
{
  return std::apply([&](const auto&... spec)
                    { return ((a.*(spec.member) == b.*(spec.member)) && ...); },
                    StepSettings::fields());
}

}  // namespace constrained_particles
