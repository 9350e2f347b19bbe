// Perspective and thin-lens cameras, Mitsuba's conventions: camera space looks
// along +Z with +Y up, and camera +X maps to the left of the image.
#ifndef VKMECH_CAMERA_GLSL
#define VKMECH_CAMERA_GLSL

// Specialization: thin lens compiled in only when the scene has one (docs/architecture.md, "Simulate only what the scene calls for").
layout(constant_id = SPEC_THIN_LENS) const bool HAS_THIN_LENS = false;
// Specialization: orthographic projection (Mitsuba's `orthographic` sensor):
// parallel rays along +Z from camera x in [-1, 1] (the film's width) and
// y in [-h/w, h/w], mapped through to_world, whose scale sizes the view.
layout(constant_id = SPEC_ORTHOGRAPHIC) const bool CAMERA_ORTHOGRAPHIC = false;

// The ray from the lens (origin, unit dir) and the part of it the camera sees, t in
// [t_range.x, t_range.y]: between its clip planes, which are depths along the camera's +Z
// (Mitsuba's near_clip and far_clip, whose rays start on the near plane; glTF's znear and zfar).
// A ray along camera-space d (d.z > 0) reaches depth z at z / d.z times d, a world distance of
// z |to_world d| / d.z: near_clip / cos(theta) for a pinhole with an unscaled to_world.
void camera_ray(vec2 film_uv, vec2 lens_u, out vec3 origin, out vec3 dir, out vec2 t_range) {
    vec3 d = vec3((1.0 - 2.0 * film_uv.x) * params.tan_half_fov_x, (1.0 - 2.0 * film_uv.y) * params.tan_half_fov_y, 1.0);
    vec3 o = vec3(0.0);
    if (CAMERA_ORTHOGRAPHIC) {
        o = vec3(d.x, d.y, 0.0);
        d = vec3(0.0, 0.0, 1.0);
    }
    if (HAS_THIN_LENS && params.aperture_radius > 0.0) {
        // Concentric-free polar mapping is fine here: only the disk matters.
        float r = params.aperture_radius * sqrt(lens_u.x);
        float phi = 6.28318530718 * lens_u.y;
        vec3 lens = vec3(r * cos(phi), r * sin(phi), 0.0);
        vec3 focus = d * params.focus_distance;  // d.z == 1: the focus plane is z = focus distance
        o = lens;
        d = focus - lens;
    }
    origin = (params.camera_to_world * vec4(o, 1.0)).xyz;
    vec3 w = (params.camera_to_world * vec4(d, 0.0)).xyz;
    dir = normalize(w);
    t_range = vec2(params.near_clip, params.far_clip) * (length(w) / d.z);
}

#endif
