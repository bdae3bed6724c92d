/// @file model.hpp
/// @brief Scene (what a user describes), State (what changes each step) and Model (a scene
/// validated and compiled for the solver, constant while it runs) — MuJoCo's model/data split.
#pragma once

#include "constrained_particles/core/constraints.hpp"
#include "constrained_particles/core/forces.hpp"
#include "constrained_particles/core/surface.hpp"
#include "constrained_particles/core/types.hpp"

#include <cstdint>
#include <string>
#include <vector>

namespace constrained_particles
{
/// A scene: the particles and the forces and constraints acting on them — and nothing else is
/// evaluated. Plain data; Model::compile() validates it.
struct Scene
{
  std::string name;                     ///< scenario or scene name, for messages
  std::vector<double> masses;           ///< one per particle [kg], > 0
  std::vector<Surface> surfaces;        ///< height fields referred to by SurfaceConstraint
  std::vector<Force> forces;            ///< applied forces
  std::vector<Constraint> constraints;  ///< rows are ordered as listed (pins excepted)
};

/// Everything that changes while simulating.
struct State
{
  Points positions;         ///< [m], 3 x n
  Points velocities;        ///< [m/s], 3 x n
  double time = 0.0;        ///< simulated time [s]
  std::uint64_t steps = 0;  ///< physics steps taken since reset
};

/// How (J W J^T) lambda = b is solved.
enum class SolveMethod
{
  Automatic,    ///< chosen from the row structure: None, Single, Tridiagonal, Tree, else Sparse
  Tridiagonal,  ///< O(n) LDL^T of a tridiagonal matrix (chains, chain hanging from a bead)
  Sparse,       ///< sparse LDL^T with a fill-reducing ordering (any structure)
  Dense,        ///< dense LDL^T, O(n^3): for tests and benchmarks
  None,         ///< resolved method when a scene has no constraint rows
  Single,       ///< one row: the closed form lambda = b / (J W J^T), no matrix
  Tree,         ///< O(n) block elimination of the particle-row graph, leaves first, when it
                ///< has no cycle (branched chains, stars, several chains); Baraff 1996
};

/// Number of SolveMethod values.
constexpr int NUM_SOLVE_METHODS = 7;

/// Name of a solve method ("tridiagonal", ...).
const char* solveMethodName(SolveMethod method);

/// One touch of a constraint row on a particle: Jacobian block `slot` of row `row`.
struct RowIncidence
{
  int row;
  int slot;
};

/// A validated scene plus the structure the solver needs. Constant during a run.
class Model
{
public:
  /// Validates the scene and precomputes inverse masses, rows and solve structure.
  /// @param method requested solve method; Tridiagonal is refused if the rows are not a chain
  /// @throws InvalidInput naming the first bad field
  static Model compile(const Scene& scene, SolveMethod method = SolveMethod::Automatic);

  const Scene& scene() const
  {
    return scene_;
  }
  int numParticles() const
  {
    return static_cast<int>(scene_.masses.size());
  }
  /// Number of scalar constraint rows (surface and link constraints; pins are eliminated).
  int numRows() const
  {
    return static_cast<int>(row_constraint_.size());
  }
  /// Number of multipliers: one per row, then three (the reaction [N]) per pin.
  int numMultipliers() const
  {
    return numRows() + 3 * static_cast<int>(pins_.size());
  }
  const std::vector<double>& masses() const
  {
    return scene_.masses;
  }
  /// W_i = 1/m_i, or 0 for a pinned particle [1/kg].
  const std::vector<double>& inverseMasses() const
  {
    return inverse_masses_;
  }
  /// The method actually used.
  SolveMethod solveMethod() const
  {
    return method_;
  }
  /// For each row, the index of its constraint in scene().constraints.
  const std::vector<int>& rowConstraints() const
  {
    return row_constraint_;
  }
  /// Indices in scene().constraints of the pins.
  const std::vector<int>& pins() const
  {
    return pins_;
  }
  /// Rows touching free particle i: incidence()[incidenceStart()[i] .. incidenceStart()[i+1]).
  const std::vector<int>& incidenceStart() const
  {
    return incidence_start_;
  }
  const std::vector<RowIncidence>& incidence() const
  {
    return incidence_;
  }
  /// Throws InvalidInput unless the state has this model's particle count and is finite.
  /// @param field name used in messages, e.g. "state"
  void validateState(const State& state, const std::string& field = "state") const;

private:
  Model() = default;

  Scene scene_;
  std::vector<double> inverse_masses_;
  std::vector<int> row_constraint_;
  std::vector<int> pins_;
  std::vector<int> incidence_start_;
  std::vector<RowIncidence> incidence_;
  SolveMethod method_ = SolveMethod::None;
};

/// True if rows touching each free particle are at most two and adjacent, so J W J^T is
/// tridiagonal in row order.
bool isTridiagonal(const Model& model);

/// True if the graph joining each row to the free particles it touches has no cycle, so the
/// Tree method solves it in O(n).
bool isForest(const Model& model);

}  // namespace constrained_particles
