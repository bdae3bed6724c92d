/// @file dopri5.hpp
/// @brief dopri5's workspace (Boost.Odeint's controlled stepper and its state), kept in Data.
/// Private to the core.
#pragma once

#include "constrained_particles/core/data.hpp"

#include <boost/numeric/odeint.hpp>

#include <vector>

namespace constrained_particles
{
/// dopri5's stepper and state, made on its first step and reused after.
struct Dopri5Workspace
{
  using OdeState = std::vector<double>;  ///< [p (3n), v (3n)]
  using Stepper = boost::numeric::odeint::controlled_runge_kutta<
      boost::numeric::odeint::runge_kutta_dopri5<OdeState>>;

  explicit Dopri5Workspace(double tolerance)
    : stepper(Stepper::error_checker_type(tolerance, tolerance)), tolerance(tolerance)
  {
  }

  Stepper stepper;
  OdeState state;
  double tolerance;  ///< the stepper's; another tolerance makes another stepper
};

}  // namespace constrained_particles
