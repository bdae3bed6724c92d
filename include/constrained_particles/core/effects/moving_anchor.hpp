/// @file moving_anchor.hpp
/// @brief A particle driven along a prescribed sinusoid, solved by elimination like a pin.
#pragma once

#include "constrained_particles/core/effect_fields.hpp"
#include "constrained_particles/core/effects/row_block.hpp"

#include <cmath>
#include <vector>

namespace constrained_particles
{
/// Particle i driven exactly along p(t) = a + A sin(2 pi f t + phi), per axis (A a 3-vector):
/// v(t) = 2 pi f A cos(.), a(t) = -(2 pi f)^2 A sin(.). Eliminated: the particle gets inverse
/// mass 0 and its position and velocity are imposed; its reaction m a(t) - f_i - (J^T lambda)_i
/// is reported like a pin's (three multipliers). With A = 0 it is a pin.
struct MovingAnchorConstraint
{
  int particle = 0;                 ///< particle index
  Vec3 anchor{ NAN, NAN, NAN };     ///< a, the centre of the motion [m]; unset: p(0) is its start
  Vec3 amplitude{ 0.0, 0.0, 0.0 };  ///< A, per axis [m]
  double frequency = 1.0;           ///< f [Hz]
  double phase = 0.0;               ///< phi [rad]

  static constexpr const char* KIND = "moving_anchor";
  static constexpr bool ELIMINATED = true;           ///< no rows: inverse mass 0
  static constexpr bool GALILEAN_INVARIANT = false;  ///< acts from outside (Model::isolated())
  static constexpr bool DRIVEN = true;  ///< moves in time: does work (isDriven, EnergyLedger)
  static constexpr auto fields()
  {
    return std::make_tuple(
        field("particle", &MovingAnchorConstraint::particle, FieldKind::Particle, nullptr,
              "particle i"),
        field("anchor", &MovingAnchorConstraint::anchor, FieldKind::Vector, &limits::COORDINATE,
              "a, centre of the motion (default: so that p(0) is where it starts)", true),
        field("amplitude", &MovingAnchorConstraint::amplitude, FieldKind::Vector,
              &limits::AMPLITUDE, "A, per axis"),
        field("frequency", &MovingAnchorConstraint::frequency, FieldKind::Number,
              &limits::FREQUENCY, "f"),
        field("phase", &MovingAnchorConstraint::phase, FieldKind::Number, &limits::PHASE, "phi"));
  }
};

/// The particle it drives.
inline int eliminatedParticle(const MovingAnchorConstraint& anchor)
{
  return anchor.particle;
}

/// p(t), v(t) and a(t), exactly.
inline ImposedMotion imposedMotion(const MovingAnchorConstraint& anchor, double time)
{
  const double omega = 2.0 * M_PI * anchor.frequency;
  const double angle = omega * time + anchor.phase;
  const double s = std::sin(angle), c = std::cos(angle);
  return { anchor.anchor + s * anchor.amplitude, (omega * c) * anchor.amplitude,
           (-omega * omega * s) * anchor.amplitude };
}

/// An unset centre puts the particle where it starts at t = 0: a = p_start - A sin(phi), so a
/// phase does not make it jump when the scene loads.
inline void fillFromStart(MovingAnchorConstraint& anchor, const std::vector<Surface>& /*surfaces*/,
                          Points& positions, Points& /*velocities*/)
{
  if (isUnset(anchor.anchor))
    anchor.anchor =
        Vec3(positions.col(anchor.particle)) - anchor.amplitude * std::sin(anchor.phase);
}

/// @throws InvalidInput naming the bad field
inline void validate(const MovingAnchorConstraint& anchor, int num_particles, int num_surfaces,
                     const std::string& prefix, bool allow_unset = false)
{
  validateFields(anchor, num_particles, num_surfaces, prefix, allow_unset);
}

}  // namespace constrained_particles
