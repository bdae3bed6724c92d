/// @file limits.hpp
/// @brief Every range the package accepts, written once with its unit. Core validation, scene
/// files, the node's parameters, its services and dynamic_reconfigure read these; the tests
/// check cfg/Simulator.cfg, config/default.yaml, srv/ and docs/node.md's tables against them
/// (test/ros/test_documented_ranges.cpp).
#pragma once

#include "constrained_particles/core/types.hpp"

#include <string>
#include <vector>

namespace constrained_particles
{
/// A closed or half-open interval of valid values with its unit, e.g. (0, 1e6] [kg].
struct Range
{
  double low;        ///< lower bound
  bool low_open;     ///< true: low itself is refused
  double high;       ///< upper bound, always included
  const char* unit;  ///< SI unit as written in messages ("kg", "m/s^2", "1" for pure numbers)
  bool integer;      ///< whole numbers only (counts, iterations)

  /// True if value is finite, inside the interval and (if integer) whole.
  bool contains(double value) const;
  /// "(0, 1e+06]": the interval alone, as docs/node.md's and default.yaml's range columns write it.
  std::string interval() const;
  /// "(0, 1e+06] [kg]": how messages write the range.
  std::string text() const;
};

/// Throws InvalidInput naming `field` ("= <value>, must be in <range>") unless range contains it.
void requireInRange(const std::string& field, double value, const Range& range);

/// Throws InvalidInput naming `field.x`, `field.y` or `field.z` unless each is in range.
void requireInRange(const std::string& field, const Vec3& value, const Range& range);

namespace limits
{
// --- particles and scenes ---
/// Particle mass m [kg]: 1 microgram to 1,000 t (the inverse mass 1/m must stay a number).
constexpr Range MASS{ 1e-9, false, 1e6, "kg", false };
/// Particles in one scene, all chains and explicit particles together.
constexpr Range PARTICLES{ 1.0, false, 1e6, "1", true };
/// A position or anchor coordinate [m]: a teleport to 1e300 m would overflow on the first step.
constexpr Range COORDINATE{ -1e6, false, 1e6, "m", false };
/// A velocity component [m/s].
constexpr Range VELOCITY{ -1e6, false, 1e6, "m/s", false };
/// A chain's or a link's length l [m] (below a micrometre, l^2 loses the row to round-off).
constexpr Range LINK_LENGTH{ 1e-6, false, 1e3, "m", false };
/// A rotation rate component [rad/s] (a chain's initial spin).
constexpr Range ANGULAR_VELOCITY{ -1e4, false, 1e4, "rad/s", false };
/// A direction or normal component (normalised after reading; all zero is refused) [1].
constexpr Range DIRECTION{ -1e6, false, 1e6, "1", false };
/// Largest scene file read [bytes]: a bigger one is refused before it is read.
constexpr long SCENE_FILE_BYTES = 1 << 20;
/// Longest surface formula [characters]: bounds parse depth and time.
constexpr std::size_t FORMULA_LENGTH = 1000;

// --- forces ---
/// A gravity component g [m/s^2] (1,000 g).
constexpr Range GRAVITY{ -1e4, false, 1e4, "m/s^2", false };
/// Linear damping c [N s/m] in f = -c v.
constexpr Range DAMPING{ 0.0, false, 1e6, "N s/m", false };
/// Quadratic drag c [kg/m] in f = -c |v| v.
constexpr Range DRAG{ 0.0, false, 1e6, "kg/m", false };
/// Coulomb's friction coefficient mu [1] of a contact (rubber on concrete is about 1).
constexpr Range FRICTION{ 0.0, false, 10.0, "1", false };
/// The largest force a hold (a frame_anchor, an ~attach) carries before it lets go [N]; 0: the
/// node's ~anchor_max_force (a scene file's field), or none (the core).
constexpr Range HOLD_FORCE{ 0.0, false, 1e9, "N", false };
/// Newton's coefficient of restitution e [1] of a contact: 0 inelastic, 1 elastic.
constexpr Range RESTITUTION{ 0.0, false, 1.0, "1", false };
/// A constant force component [N].
constexpr Range FORCE{ -1e9, false, 1e9, "N", false };
/// Spring stiffness k [N/m].
constexpr Range STIFFNESS{ 0.0, false, 1e9, "N/m", false };
/// Bending stiffness EI [N m^2] (a 1 cm steel rod: about 100).
constexpr Range BEND_STIFFNESS{ 0.0, false, 1e4, "N m^2", false };
/// Spring rest length L [m].
constexpr Range REST_LENGTH{ 0.0, false, 1e3, "m", false };

/// Shortest vector a direction field (a line's direction, a plane's normal) takes [1]: shorter
/// ones lose their direction to round-off.
constexpr double MIN_DIRECTION_LENGTH = 1e-6;

// --- surfaces (coefficients by surface type; see surface.hpp) ---
// Slopes and curvatures beyond 1e6 are not height fields a particle can follow; a zero width
// would divide by zero.
/// A plane's slope dZ/dx or dZ/dy [1].
constexpr Range SURFACE_SLOPE{ -1e6, false, 1e6, "1", false };
/// A plane's height at the origin, or a Gaussian bump's centre coordinate [m].
constexpr Range SURFACE_OFFSET{ -1e6, false, 1e6, "m", false };
/// A bowl's or saddle's curvature d2Z/dx2 or d2Z/dy2 [1/m].
constexpr Range SURFACE_CURVATURE{ 0.0, false, 1e6, "1/m", false };
/// A wave's amplitude or a Gaussian bump's height [m].
constexpr Range SURFACE_AMPLITUDE{ -1e3, false, 1e3, "m", false };
/// A wave's wavenumber along x or y [rad/m].
constexpr Range SURFACE_WAVENUMBER{ 0.0, false, 1e3, "rad/m", false };
/// A Gaussian bump's width sigma [m].
constexpr Range SURFACE_WIDTH{ 1e-6, false, 1e6, "m", false };

// --- obstacle shapes (shapes.hpp) ---
/// A shape's radius, length or side [m].
constexpr Range SHAPE_SIZE{ 1e-6, false, 1e3, "m", false };
/// A shape's roll, pitch or yaw [rad] (URDF's rpy: about fixed x, then y, then z).
constexpr Range SHAPE_ANGLE{ -1e3, false, 1e3, "rad", false };
/// Obstacle shapes in one scene (its `shapes`, with robot_links', and those ~set_obstacle adds).
constexpr Range SHAPES{ 0.0, false, 256.0, "1", true };
/// Triangles in a mesh obstacle (triangle_mesh.hpp): a closed surface has at least 4.
constexpr Range MESH_TRIANGLES{ 4.0, false, 1e6, "1", true };
/// The size of a mesh file's scale along each local axis [1] (URDF's <mesh scale>; 0.001 for a
/// file in mm; a negative factor mirrors).
constexpr Range MESH_SCALE{ 1e-6, false, 1e6, "1", false };
/// A particle's radius against obstacles [m] (a rope's thickness / 2); 0: a point.
constexpr Range PARTICLE_RADIUS{ 0.0, false, 10.0, "m", false };
/// A self-colliding rope's radius [m] (its links' against each other): over 0, as links of no
/// thickness never touch.
constexpr Range ROPE_RADIUS{ 0.0, true, 10.0, "m", false };

// --- constraints ---
/// The angle an angle constraint holds at its vertex [rad]. Straight (pi) and folded (0) are
/// refused: there the angle has no gradient (a straight joint bends two ways; one row holds one;
/// the collinear kind holds a straight joint).
constexpr Range ANGLE{ 1e-3, false, 3.14, "rad", false };
/// A driven anchor's amplitude component [m].
constexpr Range AMPLITUDE{ -1e3, false, 1e3, "m", false };
/// A driven anchor's frequency f [Hz].
constexpr Range FREQUENCY{ 0.0, false, 1e3, "Hz", false };
/// A driven anchor's phase [rad].
constexpr Range PHASE{ -1e3, false, 1e3, "rad", false };

// --- stepping (StepSettings) ---
/// Physics time step dt [s].
constexpr Range DT{ 1e-6, false, 1.0, "s", false };
/// Baumgarte frequency f [Hz], omega = 2 pi f.
constexpr Range BAUMGARTE_FREQUENCY{ 0.01, false, 1e4, "Hz", false };
/// Baumgarte damping ratio zeta [1].
constexpr Range BAUMGARTE_DAMPING_RATIO{ 0.0, false, 100.0, "1", false };
/// Largest position error projection leaves [m]; below 1e-15 m round-off decides.
constexpr Range PROJECTION_TOLERANCE{ 1e-15, false, 1.0, "m", false };
/// Newton iterations per projection.
constexpr Range PROJECTION_MAX_ITERATIONS{ 1.0, false, 1000.0, "1", true };
/// dopri5's error per internal step [1]; tighter than 1e-14 asks for more than double gives.
constexpr Range ADAPTIVE_TOLERANCE{ 1e-14, false, 1.0, "1", false };
/// Most sub-steps a step may be split into (powers of two up to it; 1 = never split) [1]:
/// 65,536 keeps one step's work bounded (a rejected step costs up to twice this many sub-steps).
constexpr Range MAX_SUBSTEPS{ 1.0, false, 65536.0, "1", true };
/// The energy ledger's residual a run may reach, as a fraction of the scene's energy scale at
/// t0 (EnergyLedger::scale) [1]; 0 = no check.
constexpr Range ENERGY_BUDGET{ 0.0, false, 1.0, "1", false };

// --- the node ---
/// Simulated seconds per wall second [1].
constexpr Range REAL_TIME_FACTOR{ 0.001, false, 100.0, "1", false };
/// tf, ~state and marker rate [Hz].
constexpr Range PUBLISH_RATE{ 0.1, false, 1000.0, "Hz", false };
/// One-line status log period [s], 0 = off.
constexpr Range STATUS_PERIOD{ 0.0, false, 3600.0, "s", false };
/// Constraint-force arrow length per newton [m/N]; 0 = scaled to the scene (the largest arrow a
/// fixed share of its region's size).
constexpr Range FORCE_SCALE{ 0.0, false, 1e3, "m/N", false };
/// Particle frames sent on /tf: -1 = all, up to DEFAULT_TF_FRAMES (warned when capped); 0 = none;
/// N = the first N.
constexpr Range TF_FRAMES{ -1.0, false, 1e6, "1", true };
/// The most particle frames /tf carries with ~tf_frames = -1 (~particles carries every particle).
constexpr int DEFAULT_TF_FRAMES = 1000;
/// How long a force ~apply_force applies acts [s]; 0 = until ~clear_forces.
constexpr Range APPLIED_FORCE_DURATION{ 0.0, false, 1e6, "s", false };
/// Constraint error beyond which the node stops stepping [m].
constexpr Range MAX_CONSTRAINT_ERROR{ 0.0, true, 1e3, "m", false };
/// Surface mesh cells per side in ~scene (2 triangles each).
constexpr Range MESH_CELLS{ 2.0, false, 200.0, "1", true };
/// Steps one ~step call may ask for.
constexpr Range STEPS_PER_CALL{ 1.0, false, 1e6, "1", true };
/// ~compare_methods: simulated time each method runs [s]; 0 = 1 s.
constexpr Range STUDY_HORIZON{ 0.0, false, 3600.0, "s", false };
/// ~compare_methods: position error the recommendation must meet [m]; 0 = 1e-6 m.
constexpr Range STUDY_ERROR_TARGET{ 0.0, false, 1e3, "m", false };
/// ~compare_methods: methods one study may list (0 = the default set).
constexpr Range STUDY_METHODS{ 0.0, false, 256.0, "1", true };
/// Window of the live accuracy estimate against a shadow reference [s]; 0 = off.
constexpr Range ACCURACY_WINDOW{ 0.0, false, 60.0, "s", false };
/// A ~wrench_command acts until a newer one or this long after it [s].
constexpr Range WRENCH_TIMEOUT{ 0.0, true, 60.0, "s", false };
/// The latency a scene with holders runs behind its clock [s], for their samples to arrive before
/// the steps reach them (HolderSession); 0: chosen from the samples' arrival.
constexpr Range ANCHOR_LAG{ 0.0, false, 10.0, "s", false };
/// A holder moving farther than this between two samples teleported: the scene is carried along
/// instead of following it [m].
constexpr Range ANCHOR_MAX_JUMP{ 0.0, true, 1e3, "m", false };
/// A holder moving faster than this between two samples teleported, like a jump [m/s].
constexpr Range ANCHOR_MAX_SPEED{ 0.0, true, 1e4, "m/s", false };

}  // namespace limits

}  // namespace constrained_particles
