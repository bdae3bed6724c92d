/// @file bending.hpp
/// @brief Bending stiffness at a rope's joint: the discrete elastic rod's bending energy.
#pragma once

#include "constrained_particles/core/effect_fields.hpp"

#include <algorithm>
#include <cmath>
#include <vector>

namespace constrained_particles
{
/// The bending energy of the joint at particle i between the links a = p_i - p_h and
/// b = p_k - p_i (h, i, k = first, middle, last), from its turning angle phi (cos phi =
/// a.b / (|a| |b|)):
///   U = EI |kappa b|^2 / (2 l),  |kappa b| = 2 tan(phi / 2),
/// the discrete elastic rod's bending term (Bergou, Wardetzky, Robinson, Audoly, Grinspun,
/// "Discrete Elastic Rods", SIGGRAPH 2008: the bending energy of an isotropic rod, their \bar l_i
/// being our 2 l),
/// with EI the bending stiffness [N m^2] and l [m] the length of rope the joint's bend is spread
/// over, half its two links' rest lengths summed. For small angles U = EI phi^2 / (2 l): the
/// integral of EI kappa^2 / 2 along the rope, kappa = phi / l. Conservative: f = -grad U,
///   f_h = -K (b^ - c a^) / |a|,  f_k = K (a^ - c b^) / |b|,  f_i = -(f_h + f_k),
/// with c = cos phi and K = 4 EI / (l (1 + c)^2). U grows without bound as the joint folds back
/// on itself (phi -> pi; 1 + c is floored at BEND_FOLD_FLOOR, so it stays finite); at phi = pi
/// exactly, and where a link has no length, the joint has no direction to bend in and exerts no
/// force. kappa b is 2 tan(phi/2) while the links are at their rest lengths (links; not a slack
/// or unlinked pair).
struct BendingForce
{
  int first = 0;           ///< particle h, before the joint
  int middle = 1;          ///< particle i, the joint
  int last = 2;            ///< particle k, after the joint
  double stiffness = 1.0;  ///< EI [N m^2], >= 0
  double length = 1.0;     ///< l [m]: (|a| + |b|) / 2 at rest

  static constexpr const char* KIND = "bend";
  static constexpr bool CONSERVATIVE = true;  ///< f = -grad U, U its potentialEnergy()
  static constexpr bool DISSIPATIVE = false;  ///< the energy ledger books its power as work in
  static constexpr bool GALILEAN_INVARIANT =
      true;  ///< between its particles only (Model::isolated())
  static constexpr auto fields()
  {
    return std::make_tuple(
        field("first", &BendingForce::first, FieldKind::Particle, nullptr,
              "particle before the joint"),
        field("middle", &BendingForce::middle, FieldKind::Particle, nullptr,
              "the joint's particle"),
        field("last", &BendingForce::last, FieldKind::Particle, nullptr,
              "particle after the joint"),
        field("stiffness", &BendingForce::stiffness, FieldKind::Number, &limits::BEND_STIFFNESS,
              "EI"),
        field("length", &BendingForce::length, FieldKind::Number, &limits::LINK_LENGTH,
              "rope length the bend is spread over, half the two links' rest lengths summed"));
  }
};

/// The floor 1 + cos phi is taken at where a joint folds back (phi -> pi), so the energy, force
/// and moment there stay finite: machine epsilon.
constexpr double BEND_FOLD_FLOOR = 2.220446049250313e-16;

/// A bend's geometry: unit links a^, b^, their lengths, c = a^.b^ and s = |a^ x b^| (cos and
/// sin phi); `bends` false where a link has no length.
struct BendGeometry
{
  Vec3 a_unit, b_unit;
  double a_length, b_length, cosine, sine;
  bool bends;
};
inline BendGeometry bendGeometry(const BendingForce& joint, const Points& positions)
{
  const Vec3 a = positions.col(joint.middle) - positions.col(joint.first);
  const Vec3 b = positions.col(joint.last) - positions.col(joint.middle);
  BendGeometry bend{ Vec3::Zero(), Vec3::Zero(), a.norm(), b.norm(), 1.0, 0.0, false };
  if (!(bend.a_length > 0.0) || !(bend.b_length > 0.0))
    return bend;
  bend.a_unit = a / bend.a_length;
  bend.b_unit = b / bend.b_length;
  // rounding can take |a^.b^| past 1
  bend.cosine = std::clamp(bend.a_unit.dot(bend.b_unit), -1.0, 1.0);
  bend.sine = bend.a_unit.cross(bend.b_unit).norm();  // no cancellation at small angles
  bend.bends = true;
  return bend;
}

/// Adds the joint's bending force to its three particles [N]. Stateless.
inline void accumulateForce(const BendingForce& joint, const std::vector<double>& /*masses*/,
                            const Points& positions, const Points& /*velocities*/, Points& forces)
{
  const BendGeometry bend = bendGeometry(joint, positions);
  if (!bend.bends)
    return;
  const double opening = std::max(1.0 + bend.cosine, BEND_FOLD_FLOOR);  // 1 + cos phi
  const double k = 4.0 * joint.stiffness / (joint.length * opening * opening);
  // b^ - c a^ is 0 where the joint folds back exactly: no direction to bend in, no force
  const Vec3 on_first = (-k / bend.a_length) * (bend.b_unit - bend.cosine * bend.a_unit);
  const Vec3 on_last = (k / bend.b_length) * (bend.a_unit - bend.cosine * bend.b_unit);
  forces.col(joint.first) += on_first;
  forces.col(joint.last) += on_last;
  forces.col(joint.middle) -= on_first + on_last;
}

/// Conservative: its work is the change of potentialEnergy(), so no power is booked: 0 [W].
inline double power(const BendingForce&, const std::vector<double>&, const Points&, const Points&)
{
  return 0.0;
}

/// EI |kappa b|^2 / (2 l) = 2 EI tan^2(phi/2) / l = 2 EI s^2 / (l (1 + c)^2) [J] (s = sin phi, the
/// half-angle tangent s / (1 + c) with no cancellation at small angles); 0 where a link has no
/// length; 1 + c floored at BEND_FOLD_FLOOR (a joint folded back exactly: finite).
inline double potentialEnergy(const BendingForce& joint, const std::vector<double>& /*masses*/,
                              const Points& positions)
{
  const BendGeometry bend = bendGeometry(joint, positions);
  if (!bend.bends)
    return 0.0;
  const double opening = std::max(1.0 + bend.cosine, BEND_FOLD_FLOOR);
  const double tangent =
      (bend.cosine > 0.0 ? bend.sine : std::sqrt(1.0 - bend.cosine) * std::sqrt(opening)) /
      opening;  // tan(phi/2): s / (1 + c), or sqrt((1 - c) / (1 + c)) near pi
  return 2.0 * joint.stiffness * tangent * tangent / joint.length;
}

/// The bending moment [N m] the joint carries, dU/dphi = 2 EI tan(phi/2) / (l cos^2(phi/2)) =
/// 4 EI tan(phi/2) / (l (1 + c)) (EI phi / l = EI kappa for small phi): >= 0, 0 on a straight
/// joint or where a link has no length; 1 + c floored at BEND_FOLD_FLOOR.
inline double bendingMoment(const BendingForce& joint, const Points& positions)
{
  const BendGeometry bend = bendGeometry(joint, positions);
  if (!bend.bends)
    return 0.0;
  const double opening = std::max(1.0 + bend.cosine, BEND_FOLD_FLOOR);
  const double tangent =
      (bend.cosine > 0.0 ? bend.sine : std::sqrt(1.0 - bend.cosine) * std::sqrt(opening)) / opening;
  return 4.0 * joint.stiffness * tangent / (joint.length * opening);
}

/// The stability estimate's row sums [N/m] of the straight rope's Hessian, EI / l g g^T with
/// g = (1, -2, 1) / l: 4 EI / l^3 at the ends, 8 EI / l^3 at the joint (16 EI / l^3 on an inner
/// particle of a rope, the fourth difference's stencil), for links of length l. A bent joint is
/// stiffer (its ends' rows 8x at a right angle, over 200x at 2.5 rad) and shorter links too; the
/// step checks catch what this misses.
inline void addStiffness(const BendingForce& joint, double* stiffness)
{
  const double unit = joint.stiffness / (joint.length * joint.length * joint.length);
  stiffness[joint.first] += 4.0 * unit;
  stiffness[joint.middle] += 8.0 * unit;
  stiffness[joint.last] += 4.0 * unit;
}

/// @throws InvalidInput naming the bad field
inline void validate(const BendingForce& joint, int num_particles, const std::string& prefix)
{
  validateFields(joint, num_particles, 0, prefix);
  if (joint.middle == joint.first)
    throw InvalidInput(prefix + ".middle",
                       "= " + std::to_string(joint.middle) + ", must differ from first");
  if (joint.last == joint.first || joint.last == joint.middle)
    throw InvalidInput(prefix + ".last",
                       "= " + std::to_string(joint.last) + ", must differ from first and middle");
}

}  // namespace constrained_particles
