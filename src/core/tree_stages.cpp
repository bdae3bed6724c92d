// The fused tree stages (issue 17): for a forest of links with at most TREE_ROWS_PER_PARTICLE
// links on a free particle (Model::fusedTree()), the row, constraint-force, solve and
// acceleration stages in two sweeps over the links in elimination order (Model::treeOrder(),
// leaves first) instead of seven: up, each link's Jacobian, right-hand side, its entries of
// J W J^T against the clique-mates eliminated before it, its row of L (left-looking LDL^T: Golub
// and Van Loan, Matrix Computations, 4th ed., Algorithm 4.1.2), pivot and forward substitution;
// down, the back substitution, the multipliers, J^T lambda and the accelerations. The elimination
// is solvers/tree_rows.cpp's (right-looking there) with its sums in another order: the same
// motion to rounding, the same counters. A singular pivot hands the stage to the generic path,
// whose factorisation regularises it. The projection stays generic (with the tree row solve).
#include "solvers/solver.hpp"
#include "stages.hpp"

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
// before it, t_a = A(q, a) - sum_{j<a} t_j L(a, j) = L(q, a) D_a; the pivot loses L(q, a) t_a and
// the forward substitution L(q, a) y_a.
inline void eliminateAgainst(const TreeClique& c, int q, double w_signed, const double* d,
                             const double* jacobians, const double* inverse_pivots, const double* y,
                             double* lower_entries, double& pivot, double& r)
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
    r -= entry * y[place];
  }
}

// Up the tree; false at a singular pivot.
bool treeSweepUp(const Model& model, Data& data, const Points& positions, const Points& velocities,
                 double& min_ratio)
{
  const TreeLink* links = model.treeLinks().data();
  const TreeClique* cliques = model.treeCliques().data();
  Vec3* jacobian = data.rows.jacobian.data();
  const double* p = positions.data();
  const double* v = velocities.data();
  const double* a0 = data.free_accelerations.data();
  const bool uniform = data.applied_forces_are_gravity;  // a0 = g on every free particle
  const ImposedMotion* imposed = data.imposed.data();
  double* jacobians = data.tree_jacobian.data();
  double* y = data.rhs.data();
  double* inverse_pivots = data.chain_inverse_pivots.data();
  double* lower_entries = data.tree_lower.data();
  min_ratio = 1.0;
  const int m = model.numRows();
  for (int k = 0; k < m; ++k)
  {
    const TreeLink& link = links[k];
    const double* pi = p + 3 * link.first;
    const double* pj = p + 3 * link.second;
    const double dx = pi[0] - pj[0], dy = pi[1] - pj[1], dz = pi[2] - pj[2];
    double* d = jacobians + 3 * k;
    d[0] = dx;
    d[1] = dy;
    d[2] = dz;
    jacobian[link.block] = Vec3(dx, dy, dz);
    jacobian[link.block + 1] = Vec3(-dx, -dy, -dz);
    const double squared = dx * dx + dy * dy + dz * dz;
    const double diagonal = link.w_first * squared + link.w_second * squared;
    // the right-hand side -(Jdot v + J a0) - J a_held, as chain_stages.cpp forms a link's
    const double* vi = v + 3 * link.first;
    const double* vj = v + 3 * link.second;
    const double ux = vi[0] - vj[0], uy = vi[1] - vj[1], uz = vi[2] - vj[2];
    const double jdot_v = ux * ux + uy * uy + uz * uz;
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
    double pivot = diagonal;
    if (link.clique_first >= 0)
      eliminateAgainst(cliques[link.clique_first], link.index_first, link.w_first, d, jacobians,
                       inverse_pivots, y, lower_entries, pivot, r);
    if (link.clique_second >= 0)
      eliminateAgainst(cliques[link.clique_second], link.index_second, -link.w_second, d, jacobians,
                       inverse_pivots, y, lower_entries, pivot, r);
    if (!(diagonal > 0.0))
      min_ratio = 0.0;
    else if (pivot < min_ratio * diagonal)
      min_ratio = pivot / diagonal;
    if (ConstraintSolver::isSingularPivot(pivot, diagonal))
      return false;
    inverse_pivots[k] = 1.0 / pivot;
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

// Down the tree: lambda = D^-1 y - L^T lambda, the multipliers, f_c = J^T lambda and each linked
// particle's acceleration; a particle no link touches has f_c = 0, a = a0.
void treeSweepDown(const Model& model, Data& data, Points& accelerations)
{
  const TreeLink* links = model.treeLinks().data();
  const TreeClique* cliques = model.treeCliques().data();
  const double* jacobians = data.tree_jacobian.data();
  const double* inverse_pivots = data.chain_inverse_pivots.data();
  const double* lower_entries = data.tree_lower.data();
  const double* a0 = data.free_accelerations.data();
  double* lambda = data.rhs.data();
  double* multipliers = data.multipliers.data();
  double* forces = data.constraint_forces.data();
  double* a = accelerations.data();
  for (int k = model.numRows() - 1; k >= 0; --k)
  {
    const TreeLink& link = links[k];
    double value = lambda[k] * inverse_pivots[k];
    if (link.clique_first >= 0)
      value = backSubstitute(cliques[link.clique_first], link.index_first, lower_entries, lambda,
                             value);
    if (link.clique_second >= 0)
      value = backSubstitute(cliques[link.clique_second], link.index_second, lower_entries, lambda,
                             value);
    lambda[k] = multipliers[link.row] = value;
    const Vec3 force = value * Eigen::Map<const Vec3>(jacobians + 3 * k);
    settleParticle(link.first, link.first_opens, link.first_closes, link.w_first, force, a0, forces,
                   a);
    settleParticle(link.second, link.second_opens, link.second_closes, link.w_second, -force, a0,
                   forces, a);
  }
  for (int i : model.treeUnlinked())
  {
    data.constraint_forces.col(i).setZero();
    accelerations.col(i) = data.free_accelerations.col(i);
  }
}

}  // namespace

SolveReport treeForward(const Model& model, Data& data, double time, const Points& positions,
                        const Points& velocities, Points& accelerations)
{
  appliedForceStage(model, data, positions, velocities);
  // the links are counted once, as rowStage counts them, whichever path finishes the stage
  data.counters.constraints[constraintKindIndex<LinkConstraint>()] += model.numRows();
  double min_ratio = 1.0;
  if (!treeSweepUp(model, data, positions, velocities, min_ratio))
  {
    // singular: the generic stages finish the rows and regularise the factorisation
    evaluateRowRecords(model, time, positions, velocities, data.rows, nullptr);
    const SolveReport report = constraintForceStage(model, data, nullptr);
    accelerationStage(model, data, accelerations);
    return report;
  }
  const SolveReport report = countFusedFactorization(model, data, min_ratio);
  treeSweepDown(model, data, accelerations);
  addEliminatedReactions(model, data);
  heldAccelerations(model, data, accelerations);
  return report;
}

}  // namespace constrained_particles
