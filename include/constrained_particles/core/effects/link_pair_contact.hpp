/// @file link_pair_contact.hpp
/// @brief WIP (issue 48, item 2; not yet a registered kind): two links of a rope as capsules that
/// cannot pass through each other, the row's geometry only: the closest points of two segments,
/// the gap, J and Jdot v. What is left: the kind's registration (PARTICLES = 4), the run-time
/// pair set (a broad phase over the links, rows chosen as the rope moves) and the contact stage.
#pragma once

#include "constrained_particles/core/types.hpp"

#include <algorithm>
#include <array>
#include <cmath>

namespace constrained_particles
{
/// Links i-j and k-l (no particle shared), each thickened by r, apart:
/// C = min_{s,t in [0,1]} |a(s) - b(t)| - 2 r >= 0 [m], a(s) = (1 - s) p_i + s p_j,
/// b(t) = (1 - t) p_k + t p_l. At the minimiser (s*, t*), with w = a - b and n = w / |w|, the
/// envelope theorem gives J = ((1 - s*) n, s* n, -(1 - t*) n, -t* n); the minimiser moves with
/// the state, so (D(s, t) = |a(s) - b(t)|, its Hessian H over the free parameters, those strictly
/// inside [0, 1], and g the time derivative of D's gradient at fixed (s, t))
///   Jdot v = (|w'|^2 - (n . w')^2) / |w| - g^T H^-1 g,
/// w' = (1 - s*) v_i + s* v_j - (1 - t*) v_k - t* v_l, as segment_contact.hpp's row (there one
/// parameter). Parallel links have a line of minimisers (H singular): the row may act only where
/// the links are not near parallel and H's free block is regular (`between`), as a link flat on a
/// face is left to its particles. Links of zero length are not links (refused where kinds are).
struct LinkPairContact
{
  int first_a = 0, second_a = 1;  ///< link a: particles i, j
  int first_b = 2, second_b = 3;  ///< link b: particles k, l
  double radius = 0.0;            ///< r [m]: the rope's thickness / 2
};

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
/// exactly parallel Ericson's choice jumps to an end. Such a pair is not `between`: its ends'
/// rows hold it (as a link flat on a face is held by its particles).
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

/// The pair's frame at positions p [m] and velocities v [m/s]: where (s*, t*), the unit normal
/// (from b to a), the gap C [m] and Jdot v [m/s^2] (the curvature term), and whether the row may
/// act (`between`: each free parameter's block of H regular, its smallest eigenvalue over
/// 1e-9 of its largest entry's scale).
struct LinkPairFrame
{
  double s = 0.0, t = 0.0;
  bool between = false;
  Vec3 normal = Vec3::UnitZ();
  double gap = 0.0;
  double curvature_term = 0.0;
};

inline LinkPairFrame linkPairFrame(const LinkPairContact& c, const Points& p, const Points& v)
{
  const Vec3 pi = p.col(c.first_a), pj = p.col(c.second_a), pk = p.col(c.first_b),
             pl = p.col(c.second_b);
  const SegmentPairSample near = closestOnSegments(pi, pj, pk, pl);
  LinkPairFrame out;
  out.s = near.s;
  out.t = near.t;
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
  const Vec3 dn = (dw - along * n) / d;
  out.curvature_term = (dw.squaredNorm() - along * along) / d;
  // D's Hessian in (s, t) and the time derivative of its gradient, both at fixed (s, t)
  const double h_ss = (e_a.squaredNorm() - n.dot(e_a) * n.dot(e_a)) / d;
  const double h_tt = (e_b.squaredNorm() - n.dot(e_b) * n.dot(e_b)) / d;
  const double h_st = -(e_a.dot(e_b) - n.dot(e_a) * n.dot(e_b)) / d;
  const double g_s = dn.dot(e_a) + n.dot(de_a);
  const double g_t = -(dn.dot(e_b) + n.dot(de_b));
  const double scale = 1e-9 * std::max(e_a.squaredNorm(), e_b.squaredNorm()) / d;
  if (near.parallel)
    out.between = false;
  else if (!near.s_at_bound && !near.t_at_bound)
  {
    const double det = h_ss * h_tt - h_st * h_st;
    out.between = det > scale * std::max(h_ss, h_tt);
    if (out.between)
      out.curvature_term -= (h_tt * g_s * g_s - 2.0 * h_st * g_s * g_t + h_ss * g_t * g_t) / det;
  }
  else if (!near.s_at_bound)
  {
    out.between = h_ss > scale;
    if (out.between)
      out.curvature_term -= g_s * g_s / h_ss;
  }
  else if (!near.t_at_bound)
  {
    out.between = h_tt > scale;
    if (out.between)
      out.curvature_term -= g_t * g_t / h_tt;
  }
  else
    out.between = true;  // end to end: two particles' balls, no parameter moves
  return out;
}

/// The row's Jacobian blocks on i, j, k, l (1 x 3 each, as the contact's normal shares).
inline std::array<Vec3, 4> linkPairJacobian(const LinkPairFrame& f)
{
  return { { (1.0 - f.s) * f.normal, f.s * f.normal, -(1.0 - f.t) * f.normal, -f.t * f.normal } };
}

}  // namespace constrained_particles
