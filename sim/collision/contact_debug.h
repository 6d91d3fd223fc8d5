// Debug output of stages 1-2 for ParaView: colliding vertices with their depth vectors, and their
// contact triangles, as two .vtu files (written with write_vtu, sim/io/vtu_writer.h).
#pragma once

#include <span>
#include <string>

#include "sim/collision/contact_types.h"

namespace pliant {

/// Writes `points_path`: one vertex cell per contact at the colliding vertex, with point fields
/// depth_vector (d r, m), penetration_depth (m), penetration_direction, contact_point_offset (hit - x,
/// m), depth_source, layer, triangle_source, body, vertex, penetrated_body; and `triangles_path`: the
/// contact triangle of each contact (3 points per contact, so triangles shared by several contacts
/// repeat), with fields contact (index into contacts) and barycentric (the hit's weight at the
/// corner). Throws InputError if a file cannot be written.
void write_contact_debug_vtu(const std::string& points_path, const std::string& triangles_path,
                             std::span<const CollisionBody> bodies, std::span<const VertexContact> contacts);

}  // namespace pliant
