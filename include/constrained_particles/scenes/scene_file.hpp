/// @file scene_file.hpp
/// @brief Scenes as YAML files: the description a file holds, its loader, and the expansion
/// into a core Scene and initial State (the one place chains are expanded). Uses yaml-cpp; no
/// ROS (the core stays Eigen-only).
///
/// The format is documented in docs/scenes.md and config/scenes/*.yaml. Every key is read
/// through field descriptors (effect_fields.hpp), so ranges and names are those of limits.hpp.
#pragma once

#include "constrained_particles/core/model.hpp"
#include "constrained_particles/core/scene.hpp"
#include "constrained_particles/core/settings.hpp"
#include "constrained_particles/scenes/mesh_file.hpp"

#include <optional>
#include <string>
#include <vector>

namespace constrained_particles
{
/// One explicitly listed particle.
struct ParticleSpec
{
  double mass = 1.0;             ///< [kg]
  Vec3 position = Vec3::Zero();  ///< initial position [m]
  Vec3 velocity = Vec3::Zero();  ///< initial velocity [m/s]

  static constexpr auto fields()
  {
    return std::make_tuple(
        field("mass", &ParticleSpec::mass, FieldKind::Number, &limits::MASS, "m"),
        field("position", &ParticleSpec::position, FieldKind::Vector, &limits::COORDINATE,
              "initial position"),
        field("velocity", &ParticleSpec::velocity, FieldKind::Vector, &limits::VELOCITY,
              "initial velocity"));
  }
};

/// A generated chain: `particles` particles joined by links, in a straight line.
struct ChainSpec
{
  int particles = 5;                     ///< n
  double link_length = 0.5;              ///< l [m]
  double particle_mass = 1.0;            ///< [kg]
  Vec3 start = Vec3::Zero();             ///< first particle [m]
  Vec3 direction{ 1.0, 0.0, 0.0 };       ///< along the chain (normalised), non-zero
  Vec3 velocity = Vec3::Zero();          ///< every particle's initial velocity [m/s]
  Vec3 angular_velocity = Vec3::Zero();  ///< initial spin about the chain's centre [rad/s]
  bool pin_first = false;                ///< pin the first particle where it starts
  bool pin_last = false;                 ///< pin the last particle where it starts
  std::string surface;                   ///< if set, the first particle slides on this surface
  std::string contact;       ///< if set, every particle stays on or above it (surface_contact)
  double friction = 0.0;     ///< the contacts' Coulomb mu [1]
  double restitution = 0.0;  ///< the contacts' Newton e [1]
  bool slack = false;        ///< links that go slack: at most link_length, pulling only taut
  std::vector<std::string> obstacles;  ///< shapes every particle stays out of (shape_contact)
  double radius = 0.0;                 ///< the chain's radius against its obstacles [m]
  bool capsules = false;        ///< its links too keep out of the obstacles (segment_contact)
  bool self_collision = false;  ///< its links cannot pass through each other (SelfCollision)
  double bend_stiffness = 0.0;  ///< EI [N m^2]: a bend record at every inner particle; 0: limp

  static constexpr auto fields()
  {
    return std::make_tuple(
        field("particles", &ChainSpec::particles, FieldKind::Number, &limits::PARTICLES, "n"),
        field("link_length", &ChainSpec::link_length, FieldKind::Number, &limits::LINK_LENGTH, "l"),
        field("particle_mass", &ChainSpec::particle_mass, FieldKind::Number, &limits::MASS,
              "mass of every particle"),
        field("start", &ChainSpec::start, FieldKind::Vector, &limits::COORDINATE, "first particle"),
        field("direction", &ChainSpec::direction, FieldKind::Direction, &limits::DIRECTION,
              "along the chain"),
        field("velocity", &ChainSpec::velocity, FieldKind::Vector, &limits::VELOCITY,
              "every particle's initial velocity"),
        field("angular_velocity", &ChainSpec::angular_velocity, FieldKind::Vector,
              &limits::ANGULAR_VELOCITY, "spin about the chain's centre, unpinned chains"),
        field("pin_first", &ChainSpec::pin_first, FieldKind::Flag, nullptr,
              "pin the first particle where it starts"),
        field("pin_last", &ChainSpec::pin_last, FieldKind::Flag, nullptr,
              "pin the last particle where it starts"),
        field("surface", &ChainSpec::surface, FieldKind::Surface, nullptr,
              "the first particle slides on this surface"),
        field("contact", &ChainSpec::contact, FieldKind::Surface, nullptr,
              "every particle stays on or above this surface (a surface_contact each; not the "
              "first, if it slides on it)"),
        field("friction", &ChainSpec::friction, FieldKind::Number, &limits::FRICTION,
              "the contacts' Coulomb mu"),
        field("restitution", &ChainSpec::restitution, FieldKind::Number, &limits::RESTITUTION,
              "the contacts' Newton e"),
        field("slack", &ChainSpec::slack, FieldKind::Flag, nullptr,
              "its links go slack (slack_link): at most link_length apart, pulling only taut"),
        field("obstacles", &ChainSpec::obstacles, FieldKind::Name, nullptr,
              "names of shapes every particle stays out of (a shape_contact each, with the "
              "chain's friction and restitution)"),
        field("radius", &ChainSpec::radius, FieldKind::Number, &limits::PARTICLE_RADIUS,
              "the chain's radius against its obstacles (half the rope's thickness)"),
        field("capsules", &ChainSpec::capsules, FieldKind::Flag, nullptr,
              "its links are capsules of that radius: each keeps out of every obstacle but a "
              "plane (a segment_contact each, frictionless), so no link cuts an edge"),
        field("self_collision", &ChainSpec::self_collision, FieldKind::Flag, nullptr,
              "its links are capsules of that radius that cannot pass through each other "
              "(link_pair_contact rows for the pairs near, frictionless and inelastic); the "
              "radius must be under half of link_length"),
        field("bend_stiffness", &ChainSpec::bend_stiffness, FieldKind::Number,
              &limits::BEND_STIFFNESS,
              "EI: it resists bending (a bend record at every inner particle); 0: limp"));
  }
};

/// What ~set_chain and ~chain/* change in every chain of a scene.
struct ChainChange
{
  /// n, limits::PARTICLES (and the node's ~max_particles); wide enough for any uint32 request,
  /// so an out-of-range count is refused as it was sent, never wrapped
  long num_particles = 5;
  double link_length = 0.5;    ///< l [m], limits::LINK_LENGTH
  double particle_mass = 1.0;  ///< [kg], limits::MASS
  /// chains not on a surface: pin (true) or free (false) the first particle; unset keeps it
  std::optional<bool> pin_first;
};

/// @param max_particles largest count accepted (at most limits::PARTICLES.high)
/// @param prefix field name prefix in messages ("" for a service, "~chain/" for parameters)
/// @throws InvalidInput naming the field and its valid range
void validateChainChange(const ChainChange& change, int max_particles, const std::string& prefix);

/// A scene's region of interest: the axis-aligned box its motion is expected to stay in [m]. The
/// node frames rviz's camera on it (~view), meshes surfaces over its x-y extent (~surface) and
/// scales constraint-force arrows to its size (~force_scale 0).
struct RegionSpec
{
  Vec3 low = Vec3::Zero();   ///< lowest corner [m]
  Vec3 high = Vec3::Zero();  ///< highest corner [m], >= low on every axis

  static constexpr auto fields()
  {
    return std::make_tuple(
        field("low", &RegionSpec::low, FieldKind::Vector, &limits::COORDINATE, "lowest corner"),
        field("high", &RegionSpec::high, FieldKind::Vector, &limits::COORDINATE,
              "highest corner, >= low"));
  }

  /// Radius of a sphere about center() that holds the motion [m]; 0 = half the diagonal.
  /// sceneRegion sets it (a chain's reach is a sphere, tighter than its bounding box).
  double reach = 0.0;

  Vec3 center() const
  {
    return 0.5 * (low + high);
  }
  /// `reach` if set, else half the diagonal [m].
  double radius() const
  {
    return reach > 0.0 ? reach : 0.5 * (high - low).norm();
  }
};

/// A named height field.
struct NamedSurface
{
  std::string name;
  Surface surface;
};

/// Solver settings a scene may set: any field of StepSettings; unset ones keep the caller's.
struct SolverSpec
{
  StepSettings values;             ///< the settings, the given ones as the file says
  std::vector<std::string> given;  ///< names (StepSettings::fields()) the file set
  SolveMethod solve_method = SolveMethod::Automatic;

  /// `settings` with this scene's choices applied.
  StepSettings applyTo(StepSettings settings) const;
};

/// What a scene file says. Particles are numbered explicit ones first, then each chain's.
struct SceneDescription
{
  std::string name;         ///< from `name`, else the file's stem
  std::string description;  ///< one line for humans
  std::string source;       ///< file it came from, for messages ("" if parsed from text)
  std::vector<NamedSurface> surfaces;
  std::vector<Shape> shapes;  ///< obstacles, each named (Shape::name) by its key under `shapes`
  std::vector<ParticleSpec> particles;
  std::vector<ChainSpec> chains;
  std::vector<Force> forces;
  /// surface fields index `surfaces`; fields left unset (a pin's anchor, an angle) are completed
  /// from the initial state by buildScene
  std::vector<Constraint> constraints;
  SolverSpec solver;
  std::optional<RegionSpec> region;  ///< `region`, if the file sets one (see sceneRegion)

  /// Total particle count: explicit plus every chain's.
  long numParticles() const;
};

/// A scene and the state it starts from.
struct BuiltScene
{
  Scene scene;
  State initial_state;
};

/// What a scene file may draw on from outside it.
struct SceneInputs
{
  /// The robot's URDF (the node's robot_description parameter), for `robot_links`; empty: none
  std::string robot_description;
  /// Where `package://` mesh files are (a mesh shape's `file`, a URDF's `<mesh>`); relative paths
  /// are from the scene file's directory (loadSceneFile sets it)
  FileResolver files;
};

/// Parses a scene from YAML text.
/// @param source file name used in messages
/// @param inputs what `robot_links` reads the robot from
/// @throws InvalidInput whose field is "<source>:<line>: <key path>" and whose reason says what
/// is wrong and what is valid; unknown keys are refused
SceneDescription parseScene(const std::string& yaml, const std::string& source,
                            const SceneInputs& inputs = {});

/// Reads and parses a scene file. @throws InvalidInput as parseScene, or if it cannot be read or
/// is larger than limits::SCENE_FILE_BYTES
SceneDescription loadSceneFile(const std::string& path, const SceneInputs& inputs = {});

/// The scene and initial state a description stands for: chains expanded, particles on surfaces
/// placed at z = Z(x, y) with their velocity lifted into the tangent plane, unset fields (pins at
/// their starts, angles as they start) completed by each kind's fillFromStart.
/// @param refuse_start_inside refuse a particle or link starting inside what its contact keeps
/// it out of (false: ~set_obstacle, whose change meets the running state, not the start)
/// @throws InvalidInput naming the bad field
BuiltScene buildScene(const SceneDescription& description, bool refuse_start_inside = true);

/// The scene's applied forces: the file's `forces`, in its order, then each chain's bend records
/// (bend_stiffness). buildScene's, and what a change of gravity or damping hands the Simulator.
std::vector<Force> sceneForces(const SceneDescription& description);

/// Least margin the region keeps around the particles [m].
constexpr double REGION_MARGIN = 0.25;

/// The region of interest of a scene starting from `initial` (its built initial state): the
/// particles' bounding box grown by REGION_MARGIN, joined with the file's `region` if it sets one,
/// else with a cube about each chain's first particle reaching the chain's length plus
/// REGION_MARGIN on each side (the chain can swing that far about it); then grown in z to hold
/// the surfaces over its x-y extent (where they are defined), as ~surface meshes them. Its
/// `reach` is the radius about its centre that holds the particles' box, each chain's reach
/// (a sphere) and the meshed surfaces: what a camera must see.
RegionSpec sceneRegion(const SceneDescription& description, const State& initial);

/// Names (file stems) of the *.yaml scene files in a directory, sorted.
std::vector<std::string> listScenes(const std::string& directory);

/// The file of a scene: `name_or_path` if it contains '/' or ends in .yaml, else
/// `<directory>/<name>.yaml`. @throws InvalidInput naming `field` if there is no such file
std::string resolveScene(const std::string& name_or_path, const std::string& directory,
                         const std::string& field = "scenario");

/// Applies a chain change to every chain of the scene (pin_first only to chains not on a
/// surface); a change of count or link length drops the file's `region` (sceneRegion then
/// follows the new chains). @throws InvalidInput if the scene has no chain, or names chain
/// particles by index
void setChains(SceneDescription& description, const ChainChange& change);

/// What ~set_obstacle does to an obstacle (srv/SetObstacle.srv's operation).
enum class ObstacleChange
{
  Add,      ///< a new shape, kept out by every chain (as if listed in each one's `obstacles`)
  Replace,  ///< moved, resized or retyped: in `shapes` and in every record naming it
  Remove,   ///< from `shapes`, every chain's `obstacles` and every record naming it
};

/// Applies `change` to obstacle `name`, fixed or carried (a `frame` or `topic` in `shape_yaml`).
/// `shape_yaml` is the shape as a scene file writes it under `shapes` (a YAML map: "{type: sphere,
/// position: [0, 0, 0.5], radius: 0.1}"), for Add and Replace; empty for Remove. An added shape is
/// kept out by each chain with the chain's radius, friction, restitution and capsules. A mesh's
/// `file` is found by `files`.
/// @throws InvalidInput naming `name` (empty; taken, for Add; not a shape of the scene, for
/// Replace and Remove), `shape` (its key and line, as a scene file's are named; present for
/// Remove) or `operation` (Add in a scene with no chain, or over limits::SHAPES shapes);
/// `description` is then unchanged
void changeObstacle(SceneDescription& description, ObstacleChange change, const std::string& name,
                    const std::string& shape_yaml, const FileResolver& files = {});

/// Replaces the scene's first surface. @throws InvalidInput if it has none
void setFirstSurface(SceneDescription& description, const Surface& surface);

/// The gravity [m/s^2] and linear damping [N s/m] the scene's forces hold (0 if absent).
Vec3 sceneGravity(const SceneDescription& description);
double sceneDamping(const SceneDescription& description);

/// Sets the scene's gravity and linear damping, adding, replacing or (for 0) removing those
/// force records and keeping every other force.
void setGravityAndDamping(SceneDescription& description, const Vec3& gravity, double damping);

}  // namespace constrained_particles
