/// @file link_pair_contact.hpp
/// @brief Two links of a rope as capsules that cannot pass through each other (self-collision):
/// one row between the two links' four particles that the contact stage (src/core/contact.hpp)
/// switches on and off. The Simulator makes these records itself for the link pairs of a rope a
/// broad phase finds near each other (Scene::self_collisions, self_collision.hpp); a scene may
/// also list a pair, which then stays (a pair's own row holds all four balls).
/// docs/physics.md, "Self-collision".
#pragma once

#include "constrained_particles/core/effect_fields.hpp"
#include "constrained_particles/core/effects/row_block.hpp"
#include "constrained_particles/core/types.hpp"

#include <algorithm>
#include <array>
#include <cmath>

namespace constrained_particles
{
/// How near an end of a link its closest point may lie and still be the link's [1, a fraction of
/// the link]: nearer, the point is put at the end (the particle's ball, a vertex) where the row
/// holds that ball, else kept this far from it (the row is the link's, not `between`, and is let
/// go at the step's end: two rows never become one row within a step, J W J^T singular). The
/// capsule beside the end is in by at most (LINK_END_FRACTION |e|)^2 / (2 |w|) [m] more than the
/// row says (segment_contact.hpp's bound, with the other link's distance |w| for the curvature
/// radius).
constexpr double LINK_END_FRACTION = 1e-3;

/// Links a (particles i-j) and b (k-l), sharing no particle, each thickened by r, apart:
/// C = |a(s*) - b(t*)| - 2 r >= 0 [m], a(s) = (1 - s) p_i + s p_j, b(t) = (1 - t) p_k + t p_l,
/// (s*, t*) the closest points (Ericson 2005, "Real-Time Collision Detection", 5.1.9), each put
/// at its link's end where within LINK_END_FRACTION of it and held here (then a particle's ball:
/// the vertex-edge and vertex-vertex features). With w = a - b, n = w / |w| (from b to a), the
/// envelope theorem gives J = ((1 - s*) n, s* n, -(1 - t*) n, -t* n), multiplier lambda >= 0
/// the normal force [N] (n unit), lambda C = 0. The minimiser moves with the state, so (D(s, t)
/// = |a(s) - b(t)|, H its Hessian over the free parameters (those not at an end), g the time
/// derivative of D's gradient at fixed (s, t))
///   Jdot v = (|w'|^2 - (n . w')^2) / |w| - g^T H^-1 g,
/// w' = (1 - s*) v_i + s* v_j - (1 - t*) v_k - t* v_l (segment_contact.hpp's row with a second
/// parameter). A rope's particle is the end of two links: its ball is held by one pair only, the
/// one whose `holds_*` flag for that end is set (the Simulator sets them: the link that starts at
/// the particle, unless that link touches the other one); a pair whose point is at an end it does
/// not hold may not act (`LinkPairFrame::between` false), nor may links whose centre lines meet
/// (no normal); nearly parallel links have their point put at an end of their overlap.
/// Frictionless and inelastic.
struct LinkPairContact
{
  int first_a = 0, second_a = 1;  ///< link a: particles i, j
  int first_b = 2, second_b = 3;  ///< link b: particles k, l
  double radius = 0.0;            ///< r [m]: the rope's thickness / 2
  /// Whether this pair's row holds each end's ball (p_i, p_j, p_k, p_l) when its closest point is
  /// there; exactly one pair holds a particle's ball against a link (or a ball). Set where the
  /// pairs are made (nearLinkPairs), not fields: no scene file writes them.
  bool holds_first_a = true, holds_second_a = true, holds_first_b = true, holds_second_b = true;
  /// Made by the Simulator for Scene::self_collisions (replaced as pairs come near and go);
  /// false: listed by the scene, kept.
  bool generated = false;

  static constexpr const char* KIND = "link_pair_contact";
  static constexpr bool ELIMINATED = false;
  static constexpr bool GALILEAN_INVARIANT = true;  ///< between its particles only
  static constexpr bool UNILATERAL = true;          ///< rows switch on and off (contact.hpp)
  static constexpr int ROWS = 1;
  static constexpr int PARTICLES = 4;
  static constexpr auto fields()
  {
    return std::make_tuple(
        field("first_a", &LinkPairContact::first_a, FieldKind::Particle, nullptr,
              "particle i: link a starts here"),
        field("second_a", &LinkPairContact::second_a, FieldKind::Particle, nullptr,
              "particle j: link a ends here"),
        field("first_b", &LinkPairContact::first_b, FieldKind::Particle, nullptr,
              "particle k: link b starts here"),
        field("second_b", &LinkPairContact::second_b, FieldKind::Particle, nullptr,
              "particle l: link b ends here"),
        field("radius", &LinkPairContact::radius, FieldKind::Number, &limits::ROPE_RADIUS,
              "r: each link's radius (the rope's thickness / 2)"));
  }
};

/// Particles the row touches, in block order.
inline std::array<int, 4> rowParticles(const LinkPairContact& c)
{
  return { { c.first_a, c.second_a, c.first_b, c.second_b } };
}

/// Closest points of segments a0-a1 and b0-b1: fractions s, t in [0, 1] and whether each is at a
/// bound (Ericson 2005, "Real-Time Collision Detection", 5.1.9, ClosestPtSegmentSegment).
struct SegmentPairSample
{
  double s = 0.0, t = 0.0;
  bool s_at_bound = true, t_at_bound = true;
  bool parallel = false;  ///< sin^2 of the links' angle under PARALLEL_SINE2
};

/// Links closer to parallel than this (sin^2 of their angle) have a line of near-minimisers: the
/// minimiser sweeps their overlap as fast as 1 / sin^2 (the -g^T H^-1 g term grows so), and at
/// exactly parallel Ericson's choice jumps to an end. Such a pair's point is put at an end of its
/// overlap (a vertex against the other link), whose distance is over the least by at most
/// PARALLEL_SINE2 |e|^2 / (2 |w|) [m], |e| the overlap's length.
constexpr double PARALLEL_SINE2 = 1e-6;

inline SegmentPairSample closestOnSegments(const Vec3& a0, const Vec3& a1, const Vec3& b0,
                                           const Vec3& b1)
{
  const Vec3 d1 = a1 - a0, d2 = b1 - b0, r = a0 - b0;
  const double a = d1.squaredNorm(), e = d2.squaredNorm(), f = d2.dot(r);
  const double c = d1.dot(r), b = d1.dot(d2);
  const double denominator = a * e - b * b;  // >= 0; 0 for parallel segments
  double s = denominator > 0.0 ? std::clamp((b * f - c * e) / denominator, 0.0, 1.0) : 0.0;
  double t = (b * s + f) / e;
  if (t < 0.0)
  {
    t = 0.0;
    s = std::clamp(-c / a, 0.0, 1.0);
  }
  else if (t > 1.0)
  {
    t = 1.0;
    s = std::clamp((b - c) / a, 0.0, 1.0);
  }
  return { s, t, s <= 0.0 || s >= 1.0, t <= 0.0 || t >= 1.0,
           denominator <= PARALLEL_SINE2 * a * e };
}

/// The fraction along segment x0-x1 nearest point y, in [0, 1].
inline double nearestFraction(const Vec3& x0, const Vec3& x1, const Vec3& y)
{
  const Vec3 e = x1 - x0;
  const double length2 = e.squaredNorm();
  return length2 > 0.0 ? std::clamp(e.dot(y - x0) / length2, 0.0, 1.0) : 0.0;
}

/// The pair's frame at positions p [m] and velocities v [m/s]: where (s*, t*), which are at an
/// end, the unit normal (from b to a), the gap C [m], Jdot v [m/s^2] (the curvature term) and
/// Cdot [m/s] (the opening rate, n . w'), and whether the row may act (`between`).
struct LinkPairFrame
{
  double s = 0.0, t = 0.0;
  bool s_at_end = true, t_at_end = true;
  bool between = false;
  Vec3 normal = Vec3::UnitZ();
  double gap = 0.0;
  double curvature_term = 0.0;
  double opening = 0.0;
};

/// The pair's closest points (s*, t*) as its row takes them: Ericson's points (for a parallel
/// pair, the end of either link nearest the other: its overlap's end, where the distance is the
/// overlap's); then an s within LINK_END_FRACTION of an end put at that end if the row holds its
/// ball (`holds`: p_i, p_j, p_k, p_l), else at LINK_END_FRACTION from it (the row stays the
/// link's, never the same row as the ball's holder: a solve with both is regular, the row is not
/// `between` and is let go at the step's end), and t found again for it; then likewise t, and s
/// again if it is still free. `s_at_bound`, `t_at_bound`: the parameter is not free.
inline SegmentPairSample snappedClosest(const Vec3& pi, const Vec3& pj, const Vec3& pk,
                                        const Vec3& pl, const std::array<bool, 4>& holds)
{
  SegmentPairSample out = closestOnSegments(pi, pj, pk, pl);
  auto at = [&](double s, double t)
  { return ((1.0 - s) * pi + s * pj - (1.0 - t) * pk - t * pl).norm(); };
  if (out.parallel)
  {
    double least = INFINITY;
    for (const double end : { 0.0, 1.0 })
    {
      const double t = nearestFraction(pk, pl, (1.0 - end) * pi + end * pj);
      const double s = nearestFraction(pi, pj, (1.0 - end) * pk + end * pl);
      if (at(end, t) < least)
      {
        least = at(end, t);
        out.s = end;
        out.t = t;
      }
      if (at(s, end) < least)
      {
        least = at(s, end);
        out.s = s;
        out.t = end;
      }
    }
  }
  // x near an end: the end where its ball is held here, else LINK_END_FRACTION from it
  auto snap = [](double x, bool hold_first, bool hold_second, bool& bound)
  {
    bound = !(x >= LINK_END_FRACTION && x <= 1.0 - LINK_END_FRACTION);
    if (!bound)
      return x;
    return x < 0.5 ? (hold_first ? 0.0 : LINK_END_FRACTION)
                   : (hold_second ? 1.0 : 1.0 - LINK_END_FRACTION);
  };
  const double s = snap(out.s, holds[0], holds[1], out.s_at_bound);
  if (s != out.s)
    out.t = nearestFraction(pk, pl, (1.0 - s) * pi + s * pj);
  out.s = s;
  const double t = snap(out.t, holds[2], holds[3], out.t_at_bound);
  if (t != out.t && !out.s_at_bound)
    out.s =
        snap(nearestFraction(pi, pj, (1.0 - t) * pk + t * pl), holds[0], holds[1], out.s_at_bound);
  out.t = t;
  return out;
}

inline LinkPairFrame linkPairFrame(const LinkPairContact& c, const Points& p, const Points& v)
{
  const Vec3 pi = p.col(c.first_a), pj = p.col(c.second_a), pk = p.col(c.first_b),
             pl = p.col(c.second_b);
  const SegmentPairSample near = snappedClosest(
      pi, pj, pk, pl, { { c.holds_first_a, c.holds_second_a, c.holds_first_b, c.holds_second_b } });
  LinkPairFrame out;
  out.s = near.s;
  out.t = near.t;
  out.s_at_end = near.s_at_bound;
  out.t_at_end = near.t_at_bound;
  const Vec3 e_a = pj - pi, e_b = pl - pk;
  const Vec3 w = (1.0 - near.s) * pi + near.s * pj - (1.0 - near.t) * pk - near.t * pl;
  const double d = w.norm();
  out.gap = d - 2.0 * c.radius;
  if (!(d > 0.0))
    return out;  // touching centre lines: no normal (the links are 2 r inside each other)
  const Vec3 n = w / d;
  out.normal = n;
  const Vec3 de_a = v.col(c.second_a) - v.col(c.first_a),
             de_b = v.col(c.second_b) - v.col(c.first_b);
  const Vec3 dw = (1.0 - near.s) * v.col(c.first_a) + near.s * v.col(c.second_a) -
                  (1.0 - near.t) * v.col(c.first_b) - near.t * v.col(c.second_b);
  const double along = n.dot(dw);
  out.opening = along;
  const Vec3 dn = (dw - along * n) / d;
  out.curvature_term = (dw.squaredNorm() - along * along) / d;
  // a point kept off an end this row does not hold: that end is another pair's
  const bool held_s = !near.s_at_bound || near.s == 0.0 || near.s == 1.0;
  const bool held_t = !near.t_at_bound || near.t == 0.0 || near.t == 1.0;
  // D's Hessian in (s, t) and the time derivative of its gradient, both at fixed (s, t)
  const double h_ss = (e_a.squaredNorm() - n.dot(e_a) * n.dot(e_a)) / d;
  const double h_tt = (e_b.squaredNorm() - n.dot(e_b) * n.dot(e_b)) / d;
  const double h_st = -(e_a.dot(e_b) - n.dot(e_a) * n.dot(e_b)) / d;
  const double g_s = dn.dot(e_a) + n.dot(de_a);
  const double g_t = -(dn.dot(e_b) + n.dot(de_b));
  const double scale = 1e-9 * std::max(e_a.squaredNorm(), e_b.squaredNorm()) / d;
  bool regular = true;
  if (!near.s_at_bound && !near.t_at_bound)
  {
    const double det = h_ss * h_tt - h_st * h_st;
    regular = det > scale * std::max(h_ss, h_tt);
    if (regular)
      out.curvature_term -= (h_tt * g_s * g_s - 2.0 * h_st * g_s * g_t + h_ss * g_t * g_t) / det;
  }
  else if (!near.s_at_bound)
  {
    regular = h_ss > scale;
    if (regular)
      out.curvature_term -= g_s * g_s / h_ss;
  }
  else if (!near.t_at_bound)
  {
    regular = h_tt > scale;
    if (regular)
      out.curvature_term -= g_t * g_t / h_tt;
  }
  out.between = regular && held_s && held_t;
  return out;
}

/// The pair's frame at positions p [m] for its geometry only (s*, t*, the ends, between, normal,
/// gap): its rates (curvature_term, opening) are not meaningful. O(1): no velocities are made.
inline LinkPairFrame linkPairGeometry(const LinkPairContact& c, const Points& p)
{
  return linkPairFrame(c, p, p);  // the rates read velocities only; the geometry does not
}

/// The row's Jacobian blocks on i, j, k, l (1 x 3 each, as the contact's normal shares).
inline std::array<Vec3, 4> linkPairJacobian(const LinkPairFrame& f)
{
  return { { (1.0 - f.s) * f.normal, f.s * f.normal, -(1.0 - f.t) * f.normal, -f.t * f.normal } };
}

/// The row at (p, v) as if active (the contact stage zeroes it when off). Stateless.
inline void evaluateRows(const LinkPairContact& c, const EffectContext& /*context*/,
                         const Points& positions, const Points& velocities, RowBlock out)
{
  const LinkPairFrame f = linkPairFrame(c, positions, velocities);
  const std::array<Vec3, 4> jacobian = linkPairJacobian(f);
  for (int k = 0; k < 4; ++k)
    out.jacobian[k] = jacobian[k];
  out.value[0] = f.gap;
  out.jdot_v[0] = f.curvature_term;
  out.violation[0] = std::abs(f.gap);
}

/// Geometric stiffness (stability.hpp): |lambda| times the distance's Hessian (I - n n^T) / |w|,
/// its largest row sum, on each particle by its weight squared [N/m].
inline void addGeometricStiffness(const LinkPairContact& c, const EffectContext& /*context*/,
                                  const Points& positions, const double* multipliers,
                                  double* stiffness)
{
  const LinkPairFrame f = linkPairGeometry(c, positions);
  const double d = f.gap + 2.0 * c.radius;
  if (!(d > 0.0))
    return;
  const Eigen::Matrix3d projector = Eigen::Matrix3d::Identity() - f.normal * f.normal.transpose();
  const double size =
      std::abs(multipliers[0]) * projector.cwiseAbs().rowwise().sum().maxCoeff() / d;
  stiffness[c.first_a] += (1.0 - f.s) * (1.0 - f.s) * size;
  stiffness[c.second_a] += f.s * f.s * size;
  stiffness[c.first_b] += (1.0 - f.t) * (1.0 - f.t) * size;
  stiffness[c.second_b] += f.t * f.t * size;
}

/// Touching or inside, the approach speed max(0, -Cdot) [m/s]; apart, 0 (they may part).
inline void violationRates(const LinkPairContact& c, const EffectContext& /*context*/,
                           const Points& positions, const Points& velocities, double* rates)
{
  const LinkPairFrame f = linkPairFrame(c, positions, velocities);
  rates[0] = f.gap > 0.0 ? 0.0 : std::max(0.0, -f.opening);
}

/// How deep the capsules are in each other, max(0, -C) [m], where this row can act on them (an
/// end another pair holds is that pair's to report).
inline double penetration(const LinkPairContact& c, const Points& positions)
{
  const LinkPairFrame f = linkPairGeometry(c, positions);
  return f.between ? std::max(0.0, -f.gap) : 0.0;
}

/// @throws InvalidInput naming the bad field
inline void validate(const LinkPairContact& c, int num_particles, int num_surfaces,
                     const std::string& prefix, bool allow_unset = false)
{
  validateFields(c, num_particles, num_surfaces, prefix, allow_unset);
  requireDistinctParticles(c.first_a, c.second_a, prefix);
  const int particles[4] = { c.first_a, c.second_a, c.first_b, c.second_b };
  const char* names[4] = { "first_a", "second_a", "first_b", "second_b" };
  for (int x = 2; x < 4; ++x)
    for (int y = 0; y < x; ++y)
      if (particles[x] == particles[y])
        throw InvalidInput(prefix + "." + names[x],
                           "= " + std::to_string(particles[x]) + ", the same particle as " +
                               names[y] +
                               ": links that share a particle are neighbours, which "
                               "the links between them keep apart");
}

}  // namespace constrained_particles
