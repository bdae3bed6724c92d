// The fused tree stages (issue 17): for a forest of links with at most TREE_ROWS_PER_PARTICLE
// links on a free particle (Model::fusedTree()), the row, constraint-force, solve and
// acceleration stages in two sweeps over the links in elimination order (Model::treeOrder(),
// leaves first) instead of seven: up, each link's Jacobian, right-hand side, its entries of
// J W J^T against the clique-mates eliminated before it, its row of L (left-looking LDL^T: Golub
// and Van Loan, Matrix Computations, 4th ed., Algorithm 4.1.2), pivot and forward substitution;
// down, the back substitution, the multipliers, J^T lambda and the accelerations. The elimination
// is solvers/tree_rows.cpp's (right-looking there) with its sums in another order: the same
// motion to rounding, the same counters. A singular pivot hands the stage to the generic path,
// whose factorisation regularises it. The projection likewise: each Newton check's sweep also
// factorises, and the back substitution and the correction share one.
// A contact tree (Model::fusedContactTree(): links and surface contacts, and surface rows beside
// them) takes the same sweeps, a contact's row (or a surface row) one more row of one block on
// its particle's clique (its elimination there is the projected inverse mass
// w (I - n n^T / |n|^2) the rows after it see):
// the stage's rows, solve and forces without the generic stages' passes, its friction checked
// after them as contactForceStage checks it first; a stage whose friction must be solved for
// (or whose pivot is singular) is taken by the generic stages. Its projection takes the sweeps
// too, but not its reuse: a contact step's first stage takes the active set's solve instead.
#include "constrained_particles/core/effects/link_constraint.hpp"
#include "constrained_particles/core/effects/surface_contact.hpp"
#include "contact.hpp"
#include "solvers/solver.hpp"
#include "stabilization.hpp"
#include "stages.hpp"

#include <cmath>

namespace constrained_particles
{
namespace
{
constexpr int MAX_ROWS = TREE_ROWS_PER_PARTICLE;

// Entry (b, a), b > a, of a clique's packed strictly lower triangle (TreeClique).
inline int lower(int b, int a)
{
  return b * (b - 1) / 2 + a;
}

// Link k's row of L within clique c, where it is member q of the particle whose Jacobian block
// is w_signed-scaled (w_p times its sign, +1 on the link's first particle): for each member a
// before it, t_a = A(q, a) - sum_{j<a} t_j L(a, j) = L(q, a) D_a, and the pivot loses
// L(q, a) t_a.
inline void eliminateAgainst(const TreeClique& c, int q, double w_signed, const double* d,
                             const double* jacobians, const double* inverse_pivots,
                             double* lower_entries, double& pivot)
{
  double* l = lower_entries + c.offset;
  double t[MAX_ROWS];
  for (int a = 0; a < q; ++a)
  {
    const int place = c.positions[a];
    const double* da = jacobians + 3 * place;
    double e = (w_signed * c.signs[a]) * (d[0] * da[0] + d[1] * da[1] + d[2] * da[2]);
    for (int j = 0; j < a; ++j)
      e -= t[j] * l[lower(a, j)];
    t[a] = e;
    const double entry = e * inverse_pivots[place];
    l[lower(q, a)] = entry;
    pivot -= entry * e;
  }
}

// The forward substitution of link k (member q of clique c): r -= L(q, a) y_a.
inline void substituteAgainst(const TreeClique& c, int q, const double* lower_entries,
                              const double* y, double& r)
{
  const double* l = lower_entries + c.offset;
  for (int a = 0; a < q; ++a)
    r -= l[lower(q, a)] * y[c.positions[a]];
}

// Link k's row of L and its pivot from its diagonal entry (both its particles' cliques); tracks
// min(pivot / diagonal). Returns the pivot.
inline double factorLink(const TreeLink& link, const TreeClique* cliques, const double* d,
                         double diagonal, const double* jacobians, const double* inverse_pivots,
                         double* lower_entries, double& min_ratio)
{
  double pivot = diagonal;
  if (link.clique_first >= 0)
    eliminateAgainst(cliques[link.clique_first], link.index_first, link.w_first, d, jacobians,
                     inverse_pivots, lower_entries, pivot);
  if (link.clique_second >= 0)
    eliminateAgainst(cliques[link.clique_second], link.index_second, -link.w_second, d, jacobians,
                     inverse_pivots, lower_entries, pivot);
  if (!(diagonal > 0.0))
    min_ratio = 0.0;
  else if (pivot < min_ratio * diagonal)
    min_ratio = pivot / diagonal;
  return pivot;
}

// Link k's forward substitution into r against y (by place), over both its particles' cliques.
inline void substituteLink(const TreeLink& link, const TreeClique* cliques,
                           const double* lower_entries, const double* y, double& r)
{
  if (link.clique_first >= 0)
    substituteAgainst(cliques[link.clique_first], link.index_first, lower_entries, y, r);
  if (link.clique_second >= 0)
    substituteAgainst(cliques[link.clique_second], link.index_second, lower_entries, y, r);
}

// Link k's d = p_i - p_j at `positions`, kept by place (its Jacobian blocks are d and -d: the
// sweeps read them from there, and data.rows is not written); returns |d|^2.
inline double evaluateTreeLink(const TreeLink& link, int k, const double* p, double* jacobians)
{
  const LinkDelta delta = linkDelta(p + 3 * link.first, p + 3 * link.second);
  double* d = jacobians + 3 * k;
  d[0] = delta.x;
  d[1] = delta.y;
  d[2] = delta.z;
  return delta.squared;
}

// Counts one evaluation of every link, as rowStage counts them.
void countLinks(const Model& model, Data& data)
{
  data.counters.constraints[constraintKindIndex<LinkConstraint>()] += model.numRows();
}

// Counts one evaluation of every row record of a contact tree, as rowStage counts them.
void countContactTreeRows(const Model& model, Data& data)
{
  const int contacts = static_cast<int>(
      std::get<std::vector<KindRecord<SurfaceContact>>>(model.kindTables()).size());
  const int surfaces = static_cast<int>(
      std::get<std::vector<KindRecord<SurfaceConstraint>>>(model.kindTables()).size());
  data.counters.constraints[constraintKindIndex<LinkConstraint>()] +=
      model.numRows() - contacts - surfaces;
  data.counters.constraints[constraintKindIndex<SurfaceContact>()] += contacts;
  data.counters.constraints[constraintKindIndex<SurfaceConstraint>()] += surfaces;
}

// A contact tree's row of one block at place k (a contact's, `row.contact`, or a surface row's,
// `row.surface`), into data.rows as evaluateKind writes it (a contact's an identity row while it
// is off: contact.hpp) and its J by place into `jacobians`. Returns its diagonal entry of
// J W J^T.
inline double evaluateContactRowAt(const Model& model, Data& data, const TreeLink& row, int k,
                                   const EffectContext& context, const Points& positions,
                                   const Points& velocities, double* jacobians)
{
  RowData& rows = data.rows;
  const int r_index = row.row;
  Vec3& j = rows.jacobian[row.block];
  Eigen::Map<Vec3> d(jacobians + 3 * k);
  if (rows.inactive[r_index])
  {
    writeIdentityRow(rows, r_index, row.block, 1, true);
    d.setZero();
    return 1.0;
  }
  const RowBlock block{ rows.value.data() + r_index, rows.jdot_v.data() + r_index,
                        rows.violation.data() + r_index, &j, rows.time_rate.data() + r_index };
  if (row.surface >= 0)
    evaluateRows(
        std::get<std::vector<KindRecord<SurfaceConstraint>>>(model.kindTables())[row.surface]
            .record,
        context, positions, velocities, block);
  else
    evaluateRows(std::get<std::vector<KindRecord<SurfaceContact>>>(
                     model.kindTables())[model.unilateral()[row.contact].table]
                     .record,
                 context, positions, velocities, block);
  d = j;
  double diagonal = 0.0;
  diagonal += row.w_first * j.squaredNorm();
  return rows.diagonal[r_index] = diagonal;
}

// A one-block row's right-hand side -(Jdot v + J a0) as constraintForceStage sums it, from the
// row evaluateContactRowAt wrote (-0 for an identity row, as there).
inline double oneBlockRightHandSide(const Data& data, const TreeLink& row)
{
  double j_a0 = 0.0;
  j_a0 += data.rows.jacobian[row.block].dot(data.free_accelerations.col(row.first));
  double sum = data.rows.jdot_v[row.row] + 0.0;  // + 0.0: the generic sum's absent bias term
  sum += j_a0;
  return -sum;
}

// Up the tree; false at a singular pivot. REUSED: d, L and D in data are of these positions (the
// last fused projection's, FusedWorkspace::factorization): only the right-hand side and its
// forward substitution.
template <bool REUSED, bool CONTACTS = false>
bool treeSweepUp(const Model& model, Data& data, double time, const Points& positions,
                 const Points& velocities, double& min_ratio)
{
  static_assert(!(REUSED && CONTACTS),
                "a contact step's first stage reuses the active set's solve, not the projection's");
  const TreeLink* links = model.treeLinks().data();
  const TreeClique* cliques = model.treeCliques().data();
  const double* p = positions.data();
  const double* v = velocities.data();
  const double* a0 = data.free_accelerations.data();
  const bool uniform = data.applied_forces_are_gravity;  // a0 = g on every free particle
  const ImposedMotion* imposed = data.imposed.data();
  double* jacobians = data.fused.tree_jacobian.data();
  double* y = data.rhs.data();
  double* inverse_pivots = data.fused.inverse_pivots.data();
  double* lower_entries = data.fused.clique_lower.data();
  const EffectContext context = contextAt(model, data, time);
  min_ratio = 1.0;
  const int m = model.numRows();
  for (int k = 0; k < m; ++k)
  {
    const TreeLink& link = links[k];
    if constexpr (CONTACTS)
      if (link.oneBlock())
      {
        const double diagonal =
            evaluateContactRowAt(model, data, link, k, context, positions, velocities, jacobians);
        double r = oneBlockRightHandSide(data, link);
        const double pivot = factorLink(link, cliques, jacobians + 3 * k, diagonal, jacobians,
                                        inverse_pivots, lower_entries, min_ratio);
        if (ConstraintSolver::isSingularPivot(pivot, diagonal))
          return false;
        inverse_pivots[k] = 1.0 / pivot;
        substituteLink(link, cliques, lower_entries, y, r);
        y[k] = r;
        continue;
      }
    const double squared = REUSED ? 0.0 : evaluateTreeLink(link, k, p, jacobians);
    const double* d = jacobians + 3 * k;
    const double dx = d[0], dy = d[1], dz = d[2];
    // the right-hand side -(Jdot v + J a0) - J a_held (chain_stages.cpp's, summed in another
    // order: the same to rounding)
    const double jdot_v = linkJdotV(v + 3 * link.first, v + 3 * link.second);
    double r;
    if (uniform && (link.held_first & link.held_second) == -1)
      r = -jdot_v;  // J a0 = d.g + (-d).g = 0 exactly
    else
    {
      const double* ai = a0 + 3 * link.first;
      const double* aj = a0 + 3 * link.second;
      r = -(jdot_v + (dx * (ai[0] - aj[0]) + dy * (ai[1] - aj[1]) + dz * (ai[2] - aj[2])));
      if (link.held_first >= 0)
        r -= Vec3(dx, dy, dz).dot(imposed[link.held_first].acceleration);
      if (link.held_second >= 0)
        r += Vec3(dx, dy, dz).dot(imposed[link.held_second].acceleration);
    }
    if constexpr (!REUSED)
    {
      const double diagonal = linkDiagonal(link.w_first, link.w_second, squared);
      const double pivot = factorLink(link, cliques, d, diagonal, jacobians, inverse_pivots,
                                      lower_entries, min_ratio);
      if (ConstraintSolver::isSingularPivot(pivot, diagonal))
        return false;
      inverse_pivots[k] = 1.0 / pivot;
    }
    substituteLink(link, cliques, lower_entries, y, r);
    y[k] = r;
  }
  return true;
}

// lambda_k -= L(b, q) lambda_b for the members b after link k (member q) in clique c.
inline double backSubstitute(const TreeClique& c, int q, const double* lower_entries,
                             const double* lambda, double value)
{
  const double* l = lower_entries + c.offset;
  for (int b = q + 1; b < c.size; ++b)
    value -= l[lower(b, q)] * lambda[c.positions[b]];
  return value;
}

// Link k's back substitution: D^-1 y_k less L(b, k) x_b over the links b after it in both its
// particles' cliques (x by place, already solved there).
inline double backSubstituteLink(const TreeLink& link, int k, const TreeClique* cliques,
                                 const double* lower_entries, const double* inverse_pivots,
                                 const double* x)
{
  double value = x[k] * inverse_pivots[k];
  if (link.clique_first >= 0)
    value = backSubstitute(cliques[link.clique_first], link.index_first, lower_entries, x, value);
  if (link.clique_second >= 0)
    value = backSubstitute(cliques[link.clique_second], link.index_second, lower_entries, x, value);
  return value;
}

// Down the tree: lambda = D^-1 y - L^T lambda, the multipliers, f_c = J^T lambda and each linked
// particle's acceleration; a particle no link touches has f_c = 0, a = a0.
template <bool CONTACTS = false>
void treeSweepDown(const Model& model, Data& data, Points& accelerations)
{
  const TreeLink* links = model.treeLinks().data();
  const TreeClique* cliques = model.treeCliques().data();
  const double* jacobians = data.fused.tree_jacobian.data();
  const double* inverse_pivots = data.fused.inverse_pivots.data();
  const double* lower_entries = data.fused.clique_lower.data();
  const FreeAccelerations a0(model, data);
  double* lambda = data.rhs.data();
  double* multipliers = data.multipliers.data();
  double* forces = data.constraint_forces.data();
  double* a = accelerations.data();
  for (int k = model.numRows() - 1; k >= 0; --k)
  {
    const TreeLink& link = links[k];
    const double value =
        backSubstituteLink(link, k, cliques, lower_entries, inverse_pivots, lambda);
    lambda[k] = multipliers[link.row] = value;
    const Vec3 force = value * Eigen::Map<const Vec3>(jacobians + 3 * k);
    settleParticle(link.first, link.first_opens, link.first_closes, link.w_first, force, a0, forces,
                   a);
    if (CONTACTS && link.oneBlock())
      continue;  // a contact's or surface row's one block
    settleParticle(link.second, link.second_opens, link.second_closes, link.w_second, -force, a0,
                   forces, a);
  }
  for (int i : model.treeUnlinked())
  {
    data.constraint_forces.col(i).setZero();
    accelerations.col(i) = data.free_accelerations.col(i);
  }
}

// Up the tree for a projection at `positions`: the Jacobian, the largest violation
// (data.rows.max_violation), LDL^T, and the forward substitutions of C into data.rhs and of J v
// into data.fused.velocity_rhs, by place. The links' C, diagonals and violations are not stored
// in data.rows: the generic fallback evaluates its own. Returns false at a singular pivot (the
// violations are still all measured; the factorisation is then unusable).
template <bool CONTACTS = false>
bool treeProjectionSweep(const Model& model, Data& data, double time, const Points& positions,
                         const Points& velocities, double& min_ratio)
{
  const TreeLink* links = model.treeLinks().data();
  const TreeClique* cliques = model.treeCliques().data();
  const double* p = positions.data();
  const double* v = velocities.data();
  double* jacobians = data.fused.tree_jacobian.data();
  double* y = data.rhs.data();
  double* z = data.fused.velocity_rhs.data();
  double* inverse_pivots = data.fused.inverse_pivots.data();
  double* lower_entries = data.fused.clique_lower.data();
  double max_violation = 0.0;
  bool factorised = true;
  min_ratio = 1.0;
  const int m = model.numRows();
  const EffectContext context = contextAt(model, data, time);
  for (int k = 0; k < m; ++k)
  {
    const TreeLink& link = links[k];
    const double* d = jacobians + 3 * k;
    double jv, c, diagonal;
    if (CONTACTS && link.oneBlock())
    {
      // a contact's row at zero velocities, as projectPositions evaluates rows; J v as
      // multiplyJacobian sums it
      diagonal = evaluateContactRowAt(model, data, link, k, context, positions, data.stages.zero,
                                      jacobians);
      max_violation = worseError(max_violation, data.rows.violation[link.row]);
      if (!factorised)
        continue;
      jv = 0.0;
      jv += Eigen::Map<const Vec3>(d).dot(Eigen::Map<const Vec3>(v + 3 * link.first));
      c = data.rows.value[link.row];
    }
    else
    {
      const double squared = evaluateTreeLink(link, k, p, jacobians);
      // the violation and C as link_constraint.hpp's evaluateRows forms them
      max_violation = worseError(max_violation, linkViolation(squared, link.length));
      if (!factorised)
        continue;
      const double* vi = v + 3 * link.first;
      const double* vj = v + 3 * link.second;
      jv = d[0] * (vi[0] - vj[0]) + d[1] * (vi[1] - vj[1]) + d[2] * (vi[2] - vj[2]);
      c = linkValue(squared, link.length);
      diagonal = linkDiagonal(link.w_first, link.w_second, squared);
    }
    const double pivot =
        factorLink(link, cliques, d, diagonal, jacobians, inverse_pivots, lower_entries, min_ratio);
    substituteLink(link, cliques, lower_entries, y, c);
    substituteLink(link, cliques, lower_entries, z, jv);
    if (ConstraintSolver::isSingularPivot(pivot, diagonal))
    {
      factorised = false;
      continue;
    }
    inverse_pivots[k] = 1.0 / pivot;
    y[k] = c;
    z[k] = jv;
  }
  data.rows.max_violation = max_violation;
  return factorised;
}

// Down the tree: mu = D^-1 x - L^T mu from the last place, in place in `x` (by place), and
// out -= W J^T mu in the same sweep.
template <bool CONTACTS = false>
void treeCorrect(const Model& model, Data& data, Eigen::VectorXd& x, Points& out)
{
  const TreeLink* links = model.treeLinks().data();
  const TreeClique* cliques = model.treeCliques().data();
  const double* jacobians = data.fused.tree_jacobian.data();
  const double* inverse_pivots = data.fused.inverse_pivots.data();
  const double* lower_entries = data.fused.clique_lower.data();
  double* mu = x.data();
  double* o = out.data();
  for (int k = model.numRows() - 1; k >= 0; --k)
  {
    const TreeLink& link = links[k];
    const double value = backSubstituteLink(link, k, cliques, lower_entries, inverse_pivots, mu);
    mu[k] = value;
    const Eigen::Map<const Vec3> d(jacobians + 3 * k);
    // W J^T mu: w_i mu d on i, -w_j mu d on j (zero on held particles)
    Eigen::Map<Vec3>(o + 3 * link.first) -= (link.w_first * value) * d;
    if (CONTACTS && link.oneBlock())
      continue;  // a contact's or surface row's one block
    Eigen::Map<Vec3>(o + 3 * link.second) += (link.w_second * value) * d;
  }
}

}  // namespace

ProjectionReport treeProjectStep(const Model& model, Data& data, double time, Points& positions,
                                 Points& velocities, double tolerance, int max_iterations)
{
  return fusedProjectStep(model, data, time, positions, velocities, tolerance, max_iterations,
                          FusedProjection{ &treeProjectionSweep<>, &countLinks, &treeCorrect<> });
}

ProjectionReport contactTreeProjectStep(const Model& model, Data& data, double time,
                                        Points& positions, Points& velocities, double tolerance,
                                        int max_iterations)
{
  // the factorisation it keeps (FusedWorkspace::factorization) goes unread: a contact step's
  // first stage takes the active set's solve, and contactTreeForward never reuses one
  return fusedProjectStep(
      model, data, time, positions, velocities, tolerance, max_iterations,
      FusedProjection{ &treeProjectionSweep<true>, &countContactTreeRows, &treeCorrect<true> });
}

SolveReport treeForward(const Model& model, Data& data, double time, const Points& positions,
                        const Points& velocities, Points& accelerations)
{
  return fusedForward(
      model, data, time, positions, velocities, accelerations, [&] { countLinks(model, data); },
      [&](auto reused, double& min_ratio)
      {
        return treeSweepUp<decltype(reused)::value>(model, data, time, positions, velocities,
                                                    min_ratio);
      },
      [&] { treeSweepDown(model, data, accelerations); });
}

SolveReport contactTreeForward(const Model& model, Data& data, double time, const Points& positions,
                               const Points& velocities, Points& accelerations)
{
  data.noteStateChange();  // as rowStage: the positions may have moved past what was kept
  appliedForceStage(model, data, positions, velocities);
  double min_ratio = 1.0;
  // a contact sliding with friction has friction to solve for: the generic stage at once
  if (!slidesWithFriction(model, data) &&
      treeSweepUp<false, true>(model, data, time, positions, velocities, min_ratio))
  {
    treeSweepDown<true>(model, data, accelerations);
    addEliminatedReactions(model, data);
    heldAccelerations(model, data, accelerations);
    if (frictionAtRounding(model, data, velocities))
    {
      recordNormalForces(model, data);
      countContactTreeRows(model, data);
      return countFusedFactorization(model, data, min_ratio);
    }
  }
  // a singular pivot (the generic factorisation regularises it), or friction to solve for (the
  // rows and factorisation counted there)
  rowStage(model, data, time, positions, velocities, data.rows);
  const SolveReport report = contactForceStage(model, data, time, positions, velocities, nullptr);
  accelerationStage(model, data, accelerations);
  return report;
}

}  // namespace constrained_particles
