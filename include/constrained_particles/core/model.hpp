/// @file model.hpp
/// @brief Model: a scene validated and compiled for the solver, constant while it runs
/// (MuJoCo's mjModel). What changes lives in Data (data.hpp).
#pragma once

#include "constrained_particles/core/scene.hpp"

#include <cstdint>
#include <string>
#include <tuple>
#include <variant>
#include <vector>

namespace constrained_particles
{
/// How (J W J^T) lambda = b is solved; each method is one file in src/core/solvers/.
enum class SolveMethod
{
  Automatic,    ///< chosen from the row structure: None, Single, Tridiagonal, Tree, else Sparse
  Tridiagonal,  ///< O(n) LDL^T of a tridiagonal matrix (chains, chain hanging from a bead)
  Sparse,       ///< sparse LDL^T with a fill-reducing ordering (any structure)
  Dense,        ///< dense LDL^T, O(n^3): for tests and benchmarks
  None,         ///< resolved method when a scene has no constraint rows
  Single,       ///< one row: the closed form lambda = b / (J W J^T), no matrix
  Tree,         ///< O(n) block elimination of the particle-row graph, leaves first, when it
                ///< has no cycle (branched chains, stars, several chains); Baraff 1996. Where
  ///< every particle has few rows, LDL^T of J W J^T's rows (Model::solvesTreeByRows())
};

/// Number of SolveMethod values.
constexpr int NUM_SOLVE_METHODS = 7;

/// Name of a solve method ("tridiagonal", ...).
const char* solveMethodName(SolveMethod method);

class Model;
/// The algorithm `model`'s solve runs, by name: solveMethodName(), except that SolveMethod::Tree,
/// the user's one choice for a forest, names which of its two eliminations the structure took:
/// "tree (by rows)", LDL^T of J W J^T's rows (Model::solvesTreeByRows()), or "tree (by
/// particles)", the 3 x 3 block elimination (solvers/tree.cpp). What the node reports.
std::string solveAlgorithmName(const Model& model);

/// @throws InvalidInput naming `field` and the valid names
SolveMethod parseSolveMethod(const std::string& name, const std::string& field = "solve_method");

/// One touch of a constraint row on a free particle: Jacobian block `block` of row `row`.
struct RowIncidence
{
  int row;    ///< row index in [0, numRows())
  int block;  ///< block index in [0, numBlocks()): data.rows.jacobian[block]
};

/// The rows of one row-kind constraint record: `rows` consecutive rows from `first_row`, each
/// with `particles` Jacobian blocks, row-major from `first_block`.
struct RowRecord
{
  int constraint;   ///< index in scene().constraints
  int first_row;    ///< its first row
  int rows;         ///< its kind's ROWS
  int first_block;  ///< its first Jacobian block
  int particles;    ///< its kind's PARTICLES
};

/// One record of a constraint kind, with where its rows live: the hot loops run kind by kind
/// over compact arrays of these (Box2D's joint arrays), with no dispatch per record.
template <typename Kind>
struct KindRecord
{
  using KindType = Kind;
  Kind record;      ///< the constraint
  int constraint;   ///< its index in scene().constraints
  int first_row;    ///< row kinds: its first row; eliminated kinds: its index in eliminated()
  int first_block;  ///< row kinds: its first Jacobian block; eliminated kinds: its particle
};

/// One array of KindRecord per constraint kind, in registry order.
template <typename Variant>
struct KindTablesOf;
template <typename... Kinds>
struct KindTablesOf<std::variant<Kinds...>>
{
  using type = std::tuple<std::vector<KindRecord<Kinds>>...>;
};
using KindTables = KindTablesOf<Constraint>::type;

/// Which evaluation paths a model may take (chosen at compile, like the solve method).
enum class StagePaths
{
  Specialized,  ///< a structure-specialised path where the structure has one (chain_stages.cpp,
                ///< solvers/tree_rows.cpp)
  Generic,      ///< always the generic stages (the equivalence tests' reference)
};

/// The path a model's stages take in forward() and the projection (docs/architecture.md, "Which
/// path a scene takes"): the generic stages (stages.cpp), or two sweeps that fuse the row,
/// constraint-force, solve and acceleration stages for a chain (chain_stages.cpp) or a tree
/// (tree_stages.cpp) of links. Chosen once: Model::compile finds what the structure allows
/// (Model::path()), forwardPath(model, settings) (forward_path.hpp) what the settings keep.
enum class ForwardPath
{
  Generic,     ///< every stage on its own, row records by kind (stages.cpp)
  FusedChain,  ///< links and surface rows with J W J^T tridiagonal (chain_stages.cpp)
  FusedTree,   ///< links forming a tree, few rows on a particle (tree_stages.cpp)
  /// links and surface contacts (and surface rows beside them) forming a tree, few rows on a
  /// particle: the fused tree's sweeps with each contact or surface row one more row
  /// (tree_stages.cpp); a stage with friction to solve for is the generic one
  FusedContactTree,
};

/// "generic", "fused_chain", "fused_tree" or "fused_contact_tree": the name ~state and /diagnostics
/// report.
const char* forwardPathName(ForwardPath path);

/// A path and why it was chosen (one sentence, for the start-up log, ~state and /diagnostics).
struct PathChoice
{
  ForwardPath path = ForwardPath::Generic;
  std::string reason;
};

/// One row of a fused chain (Model::chainRows()): what its sweeps read, in one place. A link, or
/// a surface row (Model::chainSurfaceRecords(); its particle and inverse mass in first and
/// w_first, its flags in first_opens and first_closes).
struct ChainRow
{
  // ordered so that the record packs into 56 bytes, not 64: each stage reads it twice
  int first = 0, second = 0;             ///< the link's particles i and j
  double length = 0.0;                   ///< l [m]
  double w_first = 0.0, w_second = 0.0;  ///< their inverse masses [1/kg] (0 if held)
  /// The inverse mass [1/kg] of the particle shared with the row above times the signs of its
  /// blocks in the two rows: a link's blocks are d and -d (d = p_i - p_j), so the off-diagonal
  /// entry w J_upper.J_lower is this times d_above.d.
  double w_coupling_signed = 0.0;
  int held_first = -1, held_second = -1;  ///< index in eliminated() of their record, -1 if free
  int coupling = -1;  ///< the free particle it shares with the row above, -1 if none
  /// Down the chain (rows m-1 to 0): this row is the first to touch the particle (its J^T lambda
  /// is written, not added) and the last (its constraint force is then complete): 0 if not,
  /// CLOSES_OWN_FIRST or CLOSES_OWN_LAST, the order in which the generic stages add this row's
  /// share and the other row's to the particle (rows by kind, surface rows first, then in order).
  bool first_opens = false;
  std::uint8_t first_closes = 0;
  bool second_opens = false;
  std::uint8_t second_closes = 0;
  static constexpr std::uint8_t CLOSES_OWN_FIRST = 1;  ///< then the share of the row below
  static constexpr std::uint8_t CLOSES_OWN_LAST = 2;   ///< a link above a surface row's particle
};
static_assert(sizeof(ChainRow) <= 56, "ChainRow's fields are ordered to pack into 56 bytes");

/// Rows on one free particle beyond which the dense block of those rows (d^2 / 2 entries) costs
/// more than the particle elimination's 3 x 3 inverse (Model::solvesTreeByRows()).
constexpr int TREE_ROWS_PER_PARTICLE = 4;

/// The rows on one free particle with two or more rows, in a tree's elimination order
/// (Model::treeCliques()): rows a < b of it share only this particle (a forest), so J W J^T's
/// entry (b, a) is w J_b . J_a here, and eliminating a row updates only its clique-mates (no
/// fill). Their strictly lower triangle, of J W J^T then of L, is packed row by row: entry
/// (b, a), b > a, at offset + b (b - 1) / 2 + a.
struct TreeClique
{
  int particle = 0;
  int size = 0;    ///< d, 2 <= d <= TREE_ROWS_PER_PARTICLE
  int offset = 0;  ///< of its triangle, in a buffer of Model::treeCliqueEntries() scalars
  int rows[TREE_ROWS_PER_PARTICLE] = {};       ///< its rows, in elimination order
  int blocks[TREE_ROWS_PER_PARTICLE] = {};     ///< each row's Jacobian block on the particle
  int positions[TREE_ROWS_PER_PARTICLE] = {};  ///< each row's place in Model::treeOrder()
  /// Links only (Model::fusedTree()): +1 where the particle is the link's first (its block d),
  /// -1 where it is its second (-d).
  double signs[TREE_ROWS_PER_PARTICLE] = {};
};

/// Where a row is eliminated (Model::treeEliminatedIn()): `index` in clique `clique`, the clique
/// of its parent particle (the one it shares with rows after it), or clique -1 if it shares none.
struct TreePlace
{
  int clique = -1;
  int index = 0;
};

/// One link of a fused tree (Model::treeLinks()), at its place in the elimination order: what the
/// up and down sweeps read, in one place.
struct TreeLink
{
  int row = 0, block = 0;                 ///< its row and first Jacobian block (d; then -d)
  int first = 0, second = 0;              ///< its particles i and j
  double length = 0.0;                    ///< l [m]
  double w_first = 0.0, w_second = 0.0;   ///< their inverse masses [1/kg] (0 if held)
  int held_first = -1, held_second = -1;  ///< index in eliminated() of their record, -1 if free
  /// The clique (Model::treeCliques()) of i and of j, -1 if the particle has one row or is held,
  /// and this row's index in each.
  int clique_first = -1, clique_second = -1;
  std::int8_t index_first = 0, index_second = 0;
  /// Down the tree (places m-1 to 0): this link is the first to touch the particle (its J^T
  /// lambda is written, not added) and the last (its constraint force is then complete).
  bool first_opens = false, first_closes = false, second_opens = false, second_closes = false;
  /// A surface contact's row (ForwardPath::FusedContactTree): its index in Model::unilateral(),
  /// its one block J (the contact's normal) on `first` (`second` is `first`, w_second 0); -1
  /// otherwise.
  int contact = -1;
  /// A surface row's index in the SurfaceConstraint table (contact trees only): one block J on
  /// `first` as a contact's, always acting; -1 otherwise.
  int surface = -1;
  /// Whether the row has one block (a contact's or a surface row's), on `first`.
  bool oneBlock() const
  {
    return contact >= 0 || surface >= 0;
  }
};

/// A Jacobian block on a particle an eliminated record holds: its imposed acceleration enters the
/// right-hand side through it.
struct EliminatedBlock
{
  int block;       ///< the block
  int eliminated;  ///< index in eliminated() of the record holding its particle
};

/// What a row the contact stage switches is.
enum class UnilateralKind
{
  ParticleContact,  ///< a kind with PARTICLE_CONTACT (surface_contact, shape_contact)
  SlackLink,        ///< slack_link: taut or slack
  SegmentContact,   ///< segment_contact: a link's capsule against an obstacle
  LinkPairContact,  ///< link_pair_contact: two links' capsules against each other
};

/// One row the contact stage switches on and off (Model::unilateral()): a particle contact's,
/// a slack link's or a segment contact's.
struct UnilateralRecord
{
  int row = 0;         ///< its row
  int block = 0;       ///< its first Jacobian block
  int table = 0;       ///< its index in its kind's table
  int constraint = 0;  ///< its index in Scene::constraints
  UnilateralKind kind = UnilateralKind::ParticleContact;
  int particles[4] = {};   ///< the particles it touches (a particle contact's twice), `count`
  double friction = 0.0;   ///< a contact's Coulomb mu [1] (a link's 0)
  double restitution = 0;  ///< a contact's Newton e [1] (a link's 0)
  int count = 2;           ///< particles it touches (a particle contact's 1 in `particles` twice)
};

/// A validated scene plus the structure the solver needs. Constant during a run.
class Model
{
public:
  /// Validates the scene and precomputes inverse masses, rows and solve structure.
  /// @param method requested solve method; one the structure does not allow is refused
  /// @throws InvalidInput naming the first bad field
  /// @param paths StagePaths::Generic keeps every evaluation on the generic stages
  static Model compile(const Scene& scene, SolveMethod method = SolveMethod::Automatic,
                       StagePaths paths = StagePaths::Specialized);

  const Scene& scene() const
  {
    return scene_;
  }
  int numParticles() const
  {
    return static_cast<int>(scene_.masses.size());
  }
  /// Number of scalar constraint rows (eliminated kinds make none).
  int numRows() const
  {
    return static_cast<int>(row_start_.size()) - 1;
  }
  /// Number of Jacobian blocks (3-vectors), over all rows.
  int numBlocks() const
  {
    return static_cast<int>(block_particle_.size());
  }
  /// Number of multipliers: one per row, then three (the reaction [N]) per eliminated record.
  int numMultipliers() const
  {
    return numRows() + 3 * static_cast<int>(eliminated_.size());
  }
  /// m_i [kg]: n.
  const std::vector<double>& masses() const
  {
    return scene_.masses;
  }
  /// W_i = 1/m_i, or 0 for a particle an eliminated kind holds [1/kg]: n.
  const std::vector<double>& inverseMasses() const
  {
    return inverse_masses_;
  }
  /// Every force and constraint is GALILEAN_INVARIANT (links, angles, collinear rows, springs,
  /// gravity): no eliminated particle, nothing acting from outside. The centre of mass then
  /// falls freely and the motion about it is the scene's own, so the step checks measure the
  /// kinetic energy that motion can exchange without the centre's (energyScale()).
  bool isolated() const
  {
    return isolated_;
  }
  /// sum m_i [kg].
  double totalMass() const
  {
    return total_mass_;
  }
  /// The method actually used.
  SolveMethod solveMethod() const
  {
    return method_;
  }
  /// Every row-kind record, in scene order.
  const std::vector<RowRecord>& rowRecords() const
  {
    return row_records_;
  }
  /// Blocks of row r: [rowStart()[r], rowStart()[r + 1]): numRows() + 1.
  const std::vector<int>& rowStart() const
  {
    return row_start_;
  }
  /// Particle of each block: numBlocks().
  const std::vector<int>& blockParticle() const
  {
    return block_particle_;
  }
  /// Row of each block: numBlocks().
  const std::vector<int>& blockRow() const
  {
    return block_row_;
  }
  /// Every record by kind, compact (the stages' loops).
  const KindTables& kindTables() const
  {
    return kind_tables_;
  }
  /// Indices in scene().constraints of the eliminated records (pins, driven anchors): e.
  const std::vector<int>& eliminated() const
  {
    return eliminated_;
  }
  /// Indices in scene().constraints of the tracked records (frame anchors), in the order of
  /// their tracks (Data::tracks): t.
  const std::vector<int>& tracked() const
  {
    return tracked_;
  }
  /// The carried shapes (Shape::carried()), each once by name, in the order of their tracks
  /// (Data::carriers, ShapeContact::carrier): first met in scene order.
  const std::vector<Shape>& carriers() const
  {
    return carriers_;
  }
  bool hasCarriers() const
  {
    return !carriers_.empty();
  }
  /// The particle each eliminated record holds: e.
  const std::vector<int>& eliminatedParticles() const
  {
    return eliminated_particles_;
  }
  /// Eliminated record k's reaction in `multipliers` (numMultipliers(): rows first):
  /// r = m a(t) - f - (J^T lambda)_i [N], the force its holder exerts on particle i.
  Vec3 eliminatedReaction(const Eigen::VectorXd& multipliers, int k) const
  {
    return multipliers.segment<3>(numRows() + 3 * k);
  }
  /// The blocks touching a particle an eliminated record holds.
  const std::vector<EliminatedBlock>& eliminatedBlocks() const
  {
    return eliminated_blocks_;
  }
  /// Rows touching free particle i: incidence()[incidenceStart()[i] .. incidenceStart()[i+1]):
  /// n + 1.
  const std::vector<int>& incidenceStart() const
  {
    return incidence_start_;
  }
  /// (row, block) of each touch of a free particle by a row, grouped by particle: the total
  /// number of such touches.
  const std::vector<RowIncidence>& incidence() const
  {
    return incidence_;
  }
  /// See the namespace constant.
  static constexpr int TREE_ROWS_PER_PARTICLE = constrained_particles::TREE_ROWS_PER_PARTICLE;
  /// True if the Tree solve eliminates J W J^T's rows (solvers/tree_rows.cpp) rather than the
  /// saddle-point matrix's particles (tree.cpp): StagePaths::Specialized and at most
  /// TREE_ROWS_PER_PARTICLE rows on any free particle. Both solve the same system (a singular
  /// one regularised alike); their rounding, and the pivot ratios they report, differ.
  bool solvesTreeByRows() const
  {
    return tree_rows_;
  }
  /// solvesTreeByRows(): every row, each after the rows below it (rooted at a free particle of each
  /// tree, breadth-first, reversed); rows touching no free particle last. m.
  const std::vector<int>& treeOrder() const
  {
    return tree_order_;
  }
  /// solvesTreeByRows(): per place in treeOrder(), the clique the row is eliminated in. m.
  const std::vector<TreePlace>& treeEliminatedIn() const
  {
    return tree_eliminated_in_;
  }
  /// solvesTreeByRows(): one clique per free particle with two or more rows.
  const std::vector<TreeClique>& treeCliques() const
  {
    return tree_cliques_;
  }
  /// solvesTreeByRows(): the scalars the cliques' packed triangles take.
  int treeCliqueEntries() const
  {
    return tree_clique_entries_;
  }
  /// The path the structure allows, with its reason (forward_path.hpp's forwardPath() keeps it
  /// or, for settings a fused path does not serve, takes the generic stages).
  const PathChoice& path() const
  {
    return path_;
  }
  /// True if path() is ForwardPath::FusedTree: solvesTreeByRows() and every row a link.
  bool fusedTree() const
  {
    return path_.path == ForwardPath::FusedTree;
  }
  /// True if path() is ForwardPath::FusedContactTree: solvesTreeByRows(), every row a link, a
  /// surface contact or (beside contacts) a surface row, no carried shape.
  bool fusedContactTree() const
  {
    return path_.path == ForwardPath::FusedContactTree;
  }
  /// Fused trees and contact trees: the rows in treeOrder().
  const std::vector<TreeLink>& treeLinks() const
  {
    return tree_links_;
  }
  /// Fused trees and contact trees: the particles no row touches.
  const std::vector<int>& treeUnlinked() const
  {
    return tree_unlinked_;
  }
  /// True if path() is ForwardPath::FusedChain: every row a link or a surface row (in any
  /// order), J W J^T tridiagonal and adjacent rows sharing at most one free particle.
  bool fusedChain() const
  {
    return path_.path == ForwardPath::FusedChain;
  }
  /// Fused chains: row k's link, masses, held particles and what it shares with row k - 1.
  const std::vector<ChainRow>& chainRows() const
  {
    return chain_rows_;
  }
  /// Fused chains: how many rows are surface rows (a chain whose first particle slides on a
  /// height field has one; several chains on surfaces, one each), 0 for links only.
  int chainSurfaceRows() const
  {
    return chain_surface_rows_;
  }
  /// Fused chains with surface rows: for each row, its index in the SurfaceConstraint kind table
  /// if it is a surface row, else -1 (empty when chainSurfaceRows() is 0).
  const std::vector<int>& chainSurfaceRecords() const
  {
    return chain_surface_records_;
  }
  /// Fused chains: the particles no row touches (their constraint force is only a reaction).
  const std::vector<int>& chainUnlinked() const
  {
    return chain_unlinked_;
  }
  /// Number of rows that switch on and off (contact.hpp): the particle contacts (each
  /// PARTICLE_CONTACT kind in registry order), then the SlackLink records, then the
  /// SegmentContact records, each kind in its table's order, as Data::contacts holds them. A scene
  /// with any takes the generic stages and the tree solve (automatic, where particles and rows form
  /// a forest), the sparse or the dense one; tridiagonal and single are refused.
  int numContacts() const
  {
    return static_cast<int>(unilateral_.size());
  }
  /// Those rows, particle contacts first (Data::contacts' order).
  const std::vector<UnilateralRecord>& unilateral() const
  {
    return unilateral_;
  }
  /// How many of unilateral()'s first rows are particle contacts (the rest are slack links).
  int numParticleContacts() const
  {
    return num_particle_contacts_;
  }
  /// Throws InvalidInput unless the state has this model's particle count and is finite.
  /// @param field name used in messages, e.g. "state"
  void validateState(const State& state, const std::string& field = "state") const;

private:
  Model() = default;
  /// Appends a record to its kind's table.
  void addToKindTable(const Constraint& constraint, int index, int first_row, int first_block);

  Scene scene_;
  std::vector<double> inverse_masses_;
  bool isolated_ = false;
  double total_mass_ = 0.0;
  std::vector<RowRecord> row_records_;
  std::vector<int> row_start_{ 0 };
  std::vector<int> block_particle_;
  std::vector<int> block_row_;
  KindTables kind_tables_;
  std::vector<int> eliminated_;
  std::vector<int> tracked_;
  std::vector<int> eliminated_particles_;
  std::vector<EliminatedBlock> eliminated_blocks_;
  std::vector<int> incidence_start_;
  std::vector<RowIncidence> incidence_;
  SolveMethod method_ = SolveMethod::None;
  bool tree_rows_ = false;
  std::vector<int> tree_order_;  // solvesTreeByRows(): the elimination order and its cliques
  std::vector<TreePlace> tree_eliminated_in_;
  std::vector<TreeClique> tree_cliques_;
  int tree_clique_entries_ = 0;
  std::vector<TreeLink> tree_links_;  // empty unless fusedTree() or fusedContactTree()
  std::vector<int> tree_unlinked_;
  std::vector<ChainRow> chain_rows_;  // empty unless fusedChain()
  std::vector<int> chain_unlinked_;
  int chain_surface_rows_ = 0;
  std::vector<int> chain_surface_records_;
  std::vector<UnilateralRecord> unilateral_;
  std::vector<Shape> carriers_;
  int num_particle_contacts_ = 0;
  PathChoice path_;
};

/// The `Kind` record (a SlackLink, a SegmentContact) that unilateral row `record` stands for: its
/// entry in the kind's table.
template <typename Kind>
const Kind& unilateralRecord(const Model& model, const UnilateralRecord& record)
{
  return std::get<std::vector<KindRecord<Kind>>>(model.kindTables())[record.table].record;
}

/// The frame of particle contact `record` (one of model.unilateral()'s first
/// numParticleContacts()) at positions p [m] and velocities v [m/s] (3 x n), its obstacle where
/// `context` puts it (time, carriers): its kind's contactFrame(). Stateless.
ContactFrame contactFrame(const Model& model, const UnilateralRecord& record,
                          const EffectContext& context, const Points& p, const Points& v);

/// How deep particle contact `record`'s particle is inside what it keeps out of [m] (0 outside).
double penetration(const Model& model, const UnilateralRecord& record, const EffectContext& context,
                   const Points& p);

/// A free particle exactly two rows touch (in a chain, what couples a row to the next): the
/// particle and its touches by the earlier and the later row.
struct SharedParticle
{
  int particle;
  RowIncidence earlier, later;
};
/// Every free particle exactly two rows touch, in particle order (Model::incidence()).
std::vector<SharedParticle> sharedParticles(const Model& model);

/// True if rows touching each free particle are at most two and adjacent, so J W J^T is
/// tridiagonal in row order.
bool isTridiagonal(const Model& model);

/// True if the graph joining each row to the free particles it touches has no cycle, so the
/// Tree method solves it in O(n).
bool isForest(const Model& model);

}  // namespace constrained_particles
