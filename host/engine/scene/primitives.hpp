// Mitsuba 3's analytic shapes as triangle meshes (docs/descriptor.md §8): built in object
// space exactly as Mitsuba defines them, then moved to world space
// (positions by to_world, normals by its inverse transpose). Every triangle
// winds counter-clockwise seen from the side its normal points to, and no
// zero-area triangle is emitted.
#pragma once

#include "scene/scene.hpp"

#include <glm/glm.hpp>

namespace vkmech {

// UV-sphere resolution. The default is fine enough that refraction through a
// glass ball looks smooth with interpolated normals.
struct SphereTessellation {
    int bands = 64;      // latitude bands, pole to pole
    int segments = 128;  // longitude segments
};

// [-1,1]^2 at z = 0, normal +z, uv = (x+1)/2, (y+1)/2; flat (no normals).
Mesh make_rectangle(const glm::mat4& to_world, bool flip_normals = false);

// [-1,1]^3, 12 triangles, 4 vertices per face, outward flat normals.
Mesh make_cube(const glm::mat4& to_world, bool flip_normals = false);

// Sphere of `radius` around `center`, then to_world. Smooth analytic
// normals; uv = (phi / 2pi, theta / pi). When to_world is a similarity,
// Mesh::center/radius describe the world-space sphere; otherwise the result
// is an ellipsoid, returned as ShapeKind::Mesh with radius 0 (center is
// still its centre).
Mesh make_sphere(const glm::vec3& center, float radius, const glm::mat4& to_world, bool flip_normals = false,
                 SphereTessellation tess = {});

// Unit disk at z = 0, normal +z, polar uv (r, phi / 2pi); flat.
Mesh make_disk(const glm::mat4& to_world, bool flip_normals = false, int segments = 128);

// Open tube (no caps) from p0 to p1 of the given radius, smooth outward
// normals, uv = (phi / 2pi, t along the axis). Mitsuba defaults: p0 = 0,
// p1 = (0,0,1), radius 1.
Mesh make_cylinder(const glm::vec3& p0, const glm::vec3& p1, float radius, const glm::mat4& to_world,
                   bool flip_normals = false, int segments = 128);

}  // namespace vkmech
