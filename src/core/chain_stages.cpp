// The fused chain stages (issue 17): for a model whose rows are all links and surface rows (chains
// whose particles slide on height fields) with a tridiagonal J W J^T (Model::fusedChain()), the
// row, constraint-force, solve and acceleration stages in two
// sweeps instead of seven: up the chain, each link's Jacobian, right-hand side, LDL^T pivot
// and forward substitution; down the chain, the back substitution, the multipliers, J^T lambda
// and the accelerations. The projection likewise: each Newton check's sweep also factorises, and
// the back substitution and the correction share one. The arithmetic is the generic stages'
// (stages.cpp, stabilization.cpp and solvers/tridiagonal.cpp) in the same order, so both give the
// same motion; the same counters move, by sweep rather than by row, but for one factorisation a
// step: the first stage at the state solves with the one its last projection left there (counted
// as reused, SolveStatistics::reused_factorizations). A singular pivot hands the stage to the
// generic path, whose factorisation regularises it.
#include "constrained_particles/core/effects/link_constraint.hpp"
#include "solvers/solver.hpp"
#include "stabilization.hpp"
#include "stages.hpp"

#include <algorithm>
#include <cmath>
#include <type_traits>

namespace constrained_particles
{
namespace
{
// Raw views of the row fields a sweep writes: read through `data` the compiler reloads each
// field's pointer after every store of a double, which might (for all it knows) have moved it.
struct LinkRows
{
  explicit LinkRows(Data& data)
    : jacobian(data.fused.chain_jacobian.data())
    , value(data.rows.value.data())
    , jdot_v(data.rows.jdot_v.data())
    , diagonal(data.rows.diagonal.data())
    , violation(data.rows.violation.data())
  {
  }
  Vec3* jacobian;
  double *value, *jdot_v, *diagonal, *violation;
};

struct LinkLengths
{
  double d[3];      // d = p_i - p_j [m]: J's block on i (and -d on j)
  double squared;   // |d|^2 [m^2]
  double diagonal;  // the link's diagonal entry of J W J^T
};

// a.b summed (a0 b0 + a1 b1) + a2 b2, the order of Eigen's SSE2 dot and squaredNorm for 3-vectors
// (the generic stages'; without vectorisation, or with FMA contraction, Eigen's may differ by an
// ulp), on scalars the compiler keeps in registers (Vec3 temporaries spill in these loops)
inline double dot3(double ax, double ay, double az, const double* b)
{
  return ax * b[0] + ay * b[1] + az * b[2];
}

// Link k's Jacobian and diagonal entry of J W J^T at `positions` (link_constraint.hpp's
// evaluateRows, evaluateRowRecords' diagonal); only its first block d is stored, row after row in
// FusedWorkspace::chain_jacobian: the second is -d exactly (the sweeps read -d where the generic
// stages read the second block); not storing it, nor leaving its slot between the rows' first
// blocks as data.rows.jacobian would, saves 2.4 MB a sweep at 10^5 links. The diagonal is w_i |d|^2
// + w_j |d|^2: |-d|^2 is |d|^2 exactly, and squaredNorm sums in this order.
inline LinkLengths evaluateLink(const ChainRow& link, int k, const double* positions,
                                const LinkRows& rows)
{
  const LinkDelta d = linkDelta(positions + 3 * link.first, positions + 3 * link.second);
  double* first = rows.jacobian[k].data();
  first[0] = d.x;
  first[1] = d.y;
  first[2] = d.z;
  return { { d.x, d.y, d.z }, d.squared, linkDiagonal(link.w_first, link.w_second, d.squared) };
}

// Surface row k (Model::chainSurfaceRecords(): `record` in the surface kind table): C, Jdot v and
// the violation by the surface kind's own evaluateRows into `rows`, its one block J into
// `jacobian` (row k's of FusedWorkspace::chain_jacobian), and the diagonal entry of J W J^T summed
// as evaluateKind sums it; its J (the vector the sweeps carry on to the row below) and diagonal
// returned.
inline LinkLengths evaluateSurfaceRow(const Model& model, const ChainRow& row, int record, int k,
                                      double time, const Points& positions,
                                      const Points& velocities, RowData& rows, Vec3* jacobian)
{
  const auto& entry =
      std::get<std::vector<KindRecord<SurfaceConstraint>>>(model.kindTables())[record];
  const EffectContext context{ model.scene().surfaces, time };
  evaluateRows(entry.record, context, positions, velocities,
               RowBlock{ rows.value.data() + k, rows.jdot_v.data() + k, rows.violation.data() + k,
                         jacobian });
  const Vec3& j = *jacobian;
  double diagonal = 0.0;
  diagonal += row.w_first * j.squaredNorm();
  rows.diagonal[k] = diagonal;
  return { { j[0], j[1], j[2] }, 0.0, diagonal };
}

// The row layouts the sweeps are compiled for (Model::chainSurfaceRows()): links only; one
// surface row, row 0 (a chain under a bead: seed problem 3), then the links; surface rows
// anywhere (several chains on surfaces), looked up per row. The first two are constants in the
// sweeps' loops, with no lookup per row.
enum Layout
{
  LINKS_ONLY,
  SURFACE_ROW_0,
  ANY_SURFACE_ROWS
};

Layout layoutOf(const Model& model)
{
  const int s = model.chainSurfaceRows();
  if (s == 0)
    return LINKS_ONLY;
  return s == 1 && model.chainSurfaceRecords()[0] == 0 ? SURFACE_ROW_0 : ANY_SURFACE_ROWS;
}

// Whether row k is a surface row, for layout L.
template <Layout L>
struct RowLayout
{
  explicit RowLayout(const Model& model)
    : surface(L == ANY_SURFACE_ROWS ? model.chainSurfaceRecords().data() : nullptr)
  {
  }
  /// The row's index in the surface kind table, or -1 for a link.
  int surfaceRecord(int k) const
  {
    if constexpr (L == LINKS_ONLY)
      return -1;
    else if constexpr (L == SURFACE_ROW_0)
      return k == 0 ? 0 : -1;
    else
      return surface[k];
  }
  const int* surface;
};

// Row k's LDL^T pivot (tridiagonal.cpp's factorizeShifted at delta = 0) from the row above's d
// and inverse pivot, carried in registers rather than reloaded (the inverse pivot is the
// recurrence's critical path): sets L's entry left of it (`lower`) and tracks min(pivot /
// diagonal); the caller checks it with isSingularPivot.
inline double pivotOf(const ChainRow& link, int k, const LinkLengths& row, const double* d_above,
                      double diagonal, double inverse_pivot_above, double& lower, double& min_ratio)
{
  double pivot = diagonal;
  lower = 0.0;
  if (k > 0)
  {
    // w J_upper.J_lower with the blocks' signs in w_coupling_signed (0 if no particle is shared)
    const double off = link.coupling >= 0 ? link.w_coupling_signed *
                                                dot3(d_above[0], d_above[1], d_above[2], row.d)
                                          : 0.0;
    lower = off * inverse_pivot_above;
    pivot -= lower * off;
  }
  if (!(diagonal > 0.0))
    min_ratio = 0.0;
  else if (pivot < min_ratio * diagonal)
    min_ratio = pivot / diagonal;
  return pivot;
}

// Counts one evaluation of every row record, as rowStage counts them: the links and the surface
// rows.
void countChainRows(const Model& model, Data& data)
{
  const int s = model.chainSurfaceRows();
  data.counters.constraints[constraintKindIndex<LinkConstraint>()] += model.numRows() - s;
  data.counters.constraints[constraintKindIndex<SurfaceConstraint>()] += s;
}

// Up the chain; false at a singular pivot (the Jacobian and factorisation then hold the rows
// before it only). Only each link's first Jacobian block is stored
// (FusedWorkspace::chain_jacobian): C, Jdot v, the diagonals and the violations (a square root per
// link) are read by the projections and Baumgarte only, after evaluating rows of their own. REUSED:
// the Jacobian and LDL^T in data are of these positions (FusedWorkspace::factorization): only the
// right-hand side and its forward substitution.
template <bool REUSED, Layout L>
bool chainSweepUp(const Model& model, Data& data, double time, const Points& positions,
                  const Points& velocities, double& min_ratio)
{
  const ChainRow* links = model.chainRows().data();
  const LinkRows rows(data);
  const RowLayout<L> layout(model);
  const double* p = positions.data();
  const double* v = velocities.data();
  const double* a0 = data.free_accelerations.data();
  const bool uniform = data.applied_forces_are_gravity;  // a0 = g on every free particle
  const ImposedMotion* imposed = data.imposed.data();
  double* rhs = data.rhs.data();
  double* lower = data.fused.lower.data();
  double* inverse_pivots = data.fused.inverse_pivots.data();
  min_ratio = 1.0;
  double inverse_pivot_above = 0.0, rhs_above = 0.0, d_above[3] = { 0.0, 0.0, 0.0 };
  const int m = model.numRows();
  for (int k = 0; k < m; ++k)
  {
    const ChainRow& link = links[k];
    const int i = link.first, j = link.second;
    LinkLengths lengths;
    double r;
    if (const int record = layout.surfaceRecord(k); L != LINKS_ONLY && record >= 0)
    {
      // a surface row: evaluated anew even when reused (its Jdot v is of these velocities), the
      // right-hand side -(Jdot v + J a0) as constraintForceStage sums it (its particle is
      // never held: findChainRows)
      lengths = evaluateSurfaceRow(model, link, record, k, time, positions, velocities, data.rows,
                                   rows.jacobian + k);
      const double j_a0 = 0.0 + dot3(lengths.d[0], lengths.d[1], lengths.d[2], a0 + 3 * i);
      double sum = data.rows.jdot_v[k] + 0.0;  // + 0.0: the generic sum's absent bias term
      sum += j_a0;
      r = -sum;
    }
    else
    {
      if constexpr (REUSED)
        std::copy(rows.jacobian[k].data(), rows.jacobian[k].data() + 3, lengths.d);
      else
        lengths = evaluateLink(link, k, p, rows);
      const double jdot_v = linkJdotV(v + 3 * i, v + 3 * j);
      // the right-hand side -(Jdot v + J a0) - J a_held (stages.cpp's constraintForceStage);
      // jdot_v >= 0, so jdot_v + 0.0 (the absent bias) is jdot_v
      const double dx = lengths.d[0], dy = lengths.d[1], dz = lengths.d[2];
      // both particles free: held_first = held_second = -1, all bits set (one test, not two)
      if (uniform && (link.held_first & link.held_second) == -1)
        r = -jdot_v;  // J a0 = (0 + d.g) + (-d).g = 0 exactly, and jdot_v + 0 = jdot_v
      else
      {
        double j_a0 = 0.0;
        j_a0 += dot3(dx, dy, dz, a0 + 3 * i);
        j_a0 += dot3(-dx, -dy, -dz, a0 + 3 * j);
        r = -(jdot_v + j_a0);
        if (link.held_first >= 0)
          r -= dot3(dx, dy, dz, imposed[link.held_first].acceleration.data());
        if (link.held_second >= 0)
          r -= dot3(-dx, -dy, -dz, imposed[link.held_second].acceleration.data());
      }
    }
    if constexpr (REUSED)
    {
      // the forward substitution with the L the projection left
      if (k > 0)
        r -= lower[k - 1] * rhs_above;
      rhs_above = rhs[k] = r;
      continue;
    }
    // the pivot and the forward substitution
    const double diagonal = lengths.diagonal;
    double l = 0.0;
    const double pivot =
        pivotOf(link, k, lengths, d_above, diagonal, inverse_pivot_above, l, min_ratio);
    std::copy(lengths.d, lengths.d + 3, d_above);
    if (k > 0)
    {
      lower[k - 1] = l;
      r -= l * rhs_above;
    }
    if (ConstraintSolver::isSingularPivot(pivot, diagonal))
      return false;
    inverse_pivot_above = inverse_pivots[k] = 1.0 / pivot;
    rhs_above = rhs[k] = r;
  }
  return true;
}

// Down the chain: lambda = D^-1 y - L^T lambda, the multipliers, f_c = J^T lambda and each
// linked particle's acceleration; a particle no row touches has f_c = 0, a = a0.
template <Layout L>
void chainSweepDown(const Model& model, Data& data, Points& accelerations)
{
  const ChainRow* links = model.chainRows().data();
  const RowLayout<L> layout(model);
  const Vec3* jacobian = data.fused.chain_jacobian.data();
  const double* lower = data.fused.lower.data();
  const double* inverse_pivots = data.fused.inverse_pivots.data();
  const FreeAccelerations a0(model, data);
  double* rhs = data.rhs.data();
  double* multipliers = data.multipliers.data();
  double* forces = data.constraint_forces.data();
  double* a = accelerations.data();
  const int m = model.numRows();
  double lambda_below = 0.0;
  for (int k = m - 1; k >= 0; --k)
  {
    double lambda = rhs[k] * inverse_pivots[k];
    if (k + 1 < m)
      lambda -= lower[k] * lambda_below;
    lambda_below = rhs[k] = multipliers[k] = lambda;
    const ChainRow& link = links[k];
    const Vec3 force = lambda * jacobian[k];
    settleParticle(link.first, link.first_opens, link.first_closes, link.w_first, force, a0, forces,
                   a);
    // a surface row has one block; a link's second is -d: lambda (-d) is -(lambda d) exactly
    if (L == LINKS_ONLY || layout.surfaceRecord(k) < 0)
      settleParticle(link.second, link.second_opens, link.second_closes, link.w_second, -force, a0,
                     forces, a);
  }
  const auto& w = model.inverseMasses();
  for (int i : model.chainUnlinked())
  {
    data.constraint_forces.col(i).setZero();
    accelerations.col(i) = data.free_accelerations.col(i) + w[i] * data.constraint_forces.col(i);
  }
}

// Up the chain for a projection at `positions`: the Jacobian blocks, the largest violation
// (data.rows.max_violation), LDL^T, and the forward substitutions of C into data.rhs and of J v
// into data.fused.velocity_rhs. The links' C, diagonals and violations are not stored (at 10^5
// links, 3.2 MB a sweep): the generic fallback evaluates its own rows. Returns false at a
// singular pivot (the violations are still all measured; the factorisation is then unusable).
template <Layout L>
bool chainProjectionSweep(const Model& model, Data& data, double time, const Points& positions,
                          const Points& velocities, double& min_ratio)
{
  const ChainRow* links = model.chainRows().data();
  const LinkRows rows(data);
  const RowLayout<L> layout(model);
  const double* p = positions.data();
  const double* v = velocities.data();
  double* y = data.rhs.data();
  double* z = data.fused.velocity_rhs.data();
  double* lower = data.fused.lower.data();
  double* inverse_pivots = data.fused.inverse_pivots.data();
  double max_violation = 0.0;
  bool factorised = true;
  min_ratio = 1.0;
  double inverse_pivot_above = 0.0, y_above = 0.0, z_above = 0.0, d_above[3] = { 0.0, 0.0, 0.0 };
  const int m = model.numRows();
  for (int k = 0; k < m; ++k)
  {
    const ChainRow& link = links[k];
    const int i = link.first, j = link.second;
    LinkLengths lengths;
    double jv = 0.0;
    if (const int record = layout.surfaceRecord(k); L != LINKS_ONLY && record >= 0)
    {
      // a surface row at zero velocities, as projectPositions evaluates rows; J v as
      // multiplyJacobian sums it
      lengths = evaluateSurfaceRow(model, link, record, k, time, positions, data.stages.zero,
                                   data.rows, rows.jacobian + k);
      max_violation = worseError(max_violation, data.rows.violation[k]);
      jv += dot3(lengths.d[0], lengths.d[1], lengths.d[2], v + 3 * i);
    }
    else
    {
      lengths = evaluateLink(link, k, p, rows);
      max_violation = worseError(max_violation, linkViolation(lengths.squared, link.length));
      if (!factorised)
        continue;
      // J v as multiplyJacobian sums it
      jv += dot3(lengths.d[0], lengths.d[1], lengths.d[2], v + 3 * i);
      jv += dot3(-lengths.d[0], -lengths.d[1], -lengths.d[2], v + 3 * j);
    }
    if (!factorised)
      continue;
    // C as link_constraint.hpp's evaluateRows forms it (a surface row's own C for a surface row)
    double c = L != LINKS_ONLY && layout.surfaceRecord(k) >= 0
                   ? rows.value[k]
                   : linkValue(lengths.squared, link.length);
    double l = 0.0;
    const double pivot =
        pivotOf(link, k, lengths, d_above, lengths.diagonal, inverse_pivot_above, l, min_ratio);
    std::copy(lengths.d, lengths.d + 3, d_above);
    if (k > 0)
    {
      lower[k - 1] = l;
      c -= l * y_above;
      jv -= l * z_above;
    }
    if (ConstraintSolver::isSingularPivot(pivot, lengths.diagonal))
    {
      factorised = false;
      continue;
    }
    inverse_pivot_above = inverse_pivots[k] = 1.0 / pivot;
    y_above = y[k] = c;
    z_above = z[k] = jv;
  }
  data.rows.max_violation = max_violation;
  return factorised;
}

// One row's correction -W J^T mu on particle i, added in the generic order
// (addInverseMassJacobianTranspose sums rows by kind, surface rows first, then upwards; this
// sweep goes down): a particle's lower row's share waits in `pending` until its upper row's is
// added, before it or, below a surface row's share (ChainRow::CLOSES_OWN_LAST), after it.
inline void correctParticle(int i, bool opens, std::uint8_t closes, const Vec3& delta,
                            double* pending, double* out)
{
  Eigen::Map<Vec3> x(out + 3 * i);
  if (opens && closes)
    x += delta;
  else if (opens)
    Eigen::Map<Vec3>(pending + 3 * i) = delta;
  else if (closes == ChainRow::CLOSES_OWN_LAST)
  {
    x += Eigen::Map<const Vec3>(pending + 3 * i);
    x += delta;
  }
  else
  {
    x += delta;
    x += Eigen::Map<const Vec3>(pending + 3 * i);
  }
}

// Down the chain: mu = D^-1 x - L^T mu from the bottom, in place in `x` (the back half of the
// fused solve), and out -= W J^T mu (addInverseMassJacobianTranspose at scale -1) in the same
// sweep.
template <Layout L>
void chainCorrect(const Model& model, Data& data, Eigen::VectorXd& x, Points& out)
{
  const ChainRow* links = model.chainRows().data();
  const RowLayout<L> layout(model);
  const Vec3* jacobian = data.fused.chain_jacobian.data();
  const double* lower = data.fused.lower.data();
  const double* inverse_pivots = data.fused.inverse_pivots.data();
  double* mu = x.data();
  double* pending = data.fused.pending.data();
  double* o = out.data();
  const int m = model.numRows();
  double mu_below = 0.0;
  for (int k = m - 1; k >= 0; --k)
  {
    double value = mu[k] * inverse_pivots[k];
    if (k + 1 < m)
      value -= lower[k] * mu_below;
    mu_below = mu[k] = value;
    const double s = -1.0 * value;  // addInverseMassJacobianTranspose's scale * lambda
    const ChainRow& link = links[k];
    const Vec3& d = jacobian[k];
    correctParticle(link.first, link.first_opens, link.first_closes, (link.w_first * s) * d,
                    pending, o);
    // a surface row has one block; a link's second, -d, not stored: (w s)(-d) is -((w s) d)
    if (L == LINKS_ONLY || layout.surfaceRecord(k) < 0)
      correctParticle(link.second, link.second_opens, link.second_closes,
                      -((link.w_second * s) * d), pending, o);
  }
}

// Calls fn(std::integral_constant<Layout, L>{}) for the model's row layout L (layoutOf): each
// sweep compiled once per layout, the choice written once.
template <typename Fn>
decltype(auto) withLayout(const Model& model, Fn&& fn)
{
  switch (layoutOf(model))
  {
    case LINKS_ONLY:
      return fn(std::integral_constant<Layout, LINKS_ONLY>{});
    case SURFACE_ROW_0:
      return fn(std::integral_constant<Layout, SURFACE_ROW_0>{});
    default:
      return fn(std::integral_constant<Layout, ANY_SURFACE_ROWS>{});
  }
}

bool projectionSweep(const Model& model, Data& data, double time, const Points& positions,
                     const Points& velocities, double& min_ratio)
{
  return withLayout(model,
                    [&](auto layout)
                    {
                      return chainProjectionSweep<decltype(layout)::value>(
                          model, data, time, positions, velocities, min_ratio);
                    });
}

void correct(const Model& model, Data& data, Eigen::VectorXd& x, Points& out)
{
  withLayout(model,
             [&](auto layout) { chainCorrect<decltype(layout)::value>(model, data, x, out); });
}

// chainForward() for each row layout: one function each, so that the chain of links keeps the
// code (and the registers of its hot loop) it had before surface rows were fused.
template <Layout L>
#if defined(__GNUC__)
__attribute__((noinline))
#endif
SolveReport
forwardOf(const Model& model, Data& data, double time, const Points& positions,
          const Points& velocities, Points& accelerations)
{
  return fusedForward(
      model, data, time, positions, velocities, accelerations, [&] { countChainRows(model, data); },
      [&](auto reused, double& min_ratio)
      {
        return chainSweepUp<decltype(reused)::value, L>(model, data, time, positions, velocities,
                                                        min_ratio);
      },
      [&] { chainSweepDown<L>(model, data, accelerations); });
}

}  // namespace

ProjectionReport chainProjectStep(const Model& model, Data& data, double time, Points& positions,
                                  Points& velocities, double tolerance, int max_iterations)
{
  return fusedProjectStep(model, data, time, positions, velocities, tolerance, max_iterations,
                          FusedProjection{ &projectionSweep, &countChainRows, &correct });
}

SolveReport chainForward(const Model& model, Data& data, double time, const Points& positions,
                         const Points& velocities, Points& accelerations)
{
  return withLayout(model,
                    [&](auto layout)
                    {
                      return forwardOf<decltype(layout)::value>(model, data, time, positions,
                                                                velocities, accelerations);
                    });
}

}  // namespace constrained_particles
