/// @file robot_shapes.hpp
/// @brief A robot's own collision geometry as obstacles: the links a scene names under
/// `robot_links`, read from the URDF (`robot_description`), each collision element a shape
/// carried by the link's tf frame. No ROS: the caller hands the URDF text in.
#pragma once

#include "constrained_particles/core/shapes.hpp"
#include "constrained_particles/scenes/mesh_file.hpp"

#include <string>
#include <vector>

namespace constrained_particles
{
/// The collision shapes of `links` of the robot in `urdf` (URDF XML text, parsed by urdfdom, the
/// parser ROS's urdf package wraps: a well-kept library for a format that is not our trade). Each
/// collision element of a link is one shape: `frame` the link's name (robot_state_publisher's tf
/// frame for it), `position` and `rotation` the element's `<origin>` in it, a `<box>`, `<sphere>`
/// or `<cylinder>` as the shape of that type and size (URDF's conventions are shapes.hpp's), a
/// `<mesh>` as a mesh shape read from its file (`files` finds `package://` and relative names;
/// its `scale` applied; mesh_file.hpp). Named by the link, or `<link>_<k>` (k from 0, document
/// order) where a link has several.
/// @throws InvalidInput naming `field` (e.g. "robot_links") or `field[i]`: the URDF empty or not
/// parseable, a link not in it, named twice, with no collision element, a size out of
/// limits::SHAPE_SIZE, or a mesh file not found, unreadable or not a closed surface
std::vector<Shape> robotLinkShapes(const std::string& urdf, const std::vector<std::string>& links,
                                   const std::string& field, const FileResolver& files = {});

}  // namespace constrained_particles
