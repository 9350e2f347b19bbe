// Struct layouts shared by GLSL (std430 / std140) and C++ (docs/architecture.md,
// "One definition, one place"). Only vec4 / uvec4 / mat4 members, arrays of
// them, and 4-byte scalars (uint, float) in groups of four: never a bare vec3 or
// vec2, whose size or alignment differs between glm and std140/std430. host/engine/render/layout_check.cpp static_asserts every size.
#ifndef VKMECH_SHARED_TYPES_H
#define VKMECH_SHARED_TYPES_H

#ifdef __cplusplus
#include <glm/glm.hpp>
#include <cstdint>
namespace vkmech::gpu {
using vec4 = glm::vec4;
using uvec4 = glm::uvec4;
using mat4 = glm::mat4;
using uint = uint32_t;
#define VKM_CONST static constexpr uint
#define VKM_REAL static constexpr double
#else
#define VKM_CONST const uint
#define VKM_REAL const float
#endif

// Bucket indices, the paper's Table 1 order (docs/descriptor.md §2).
VKM_CONST BUCKET_EMITTER_DIRECT = 0u;
VKM_CONST BUCKET_DIRECT = 1u;
VKM_CONST BUCKET_DIFFUSE_INDIRECT = 2u;
VKM_CONST BUCKET_GLOSSY = 3u;
VKM_CONST BUCKET_DELTA_MEDIATED = 4u;
VKM_CONST BUCKET_SPECULAR_DIRECT = 5u;
VKM_CONST BUCKET_OTHER = 6u;
VKM_CONST BUCKET_COUNT = 7u;

// Tail families (docs/descriptor.md §5), bit b for bucket b: light-tailed {emitter_direct,
// direct, diffuse_indirect}, heavy-tailed {glossy, delta_mediated,
// specular_direct}; `other` is in neither.
VKM_CONST LIGHT_BUCKETS = (1u << BUCKET_EMITTER_DIRECT) | (1u << BUCKET_DIRECT) | (1u << BUCKET_DIFFUSE_INDIRECT);
VKM_CONST HEAVY_BUCKETS = (1u << BUCKET_GLOSSY) | (1u << BUCKET_DELTA_MEDIATED) | (1u << BUCKET_SPECULAR_DIRECT);

// The label of a pixel without one (zero total energy, docs/descriptor.md §3).
VKM_CONST NO_LABEL = 255u;

// A user taxonomy (docs/lpe.md; host/engine/render/taxonomy.hpp): the words of BINDING_TAXONOMY.
// Header: [0] the alphabet's size, [1] label classes, [2] the state after the camera event, [3]
// the offset of the class per state, [4] of the label class per material, [5] per area emitter;
// the transition table (state * alphabet + kind * label classes + label class) follows the
// header. Event kinds as lpe::kKind*: the camera, then reflection and transmission per lobe
// (1 + lobe, 4 + lobe), an emitter L, the background B. Classes are tally slots, at most
// BUCKET_COUNT of them.
VKM_CONST TAX_HEADER_WORDS = 8u;
VKM_CONST TAX_KIND_REFLECT = 1u;
VKM_CONST TAX_KIND_TRANSMIT = 4u;
VKM_CONST TAX_KIND_LIGHT = 7u;
VKM_CONST TAX_KIND_BACKGROUND = 8u;

// End-vertex lobes (docs/descriptor.md §2): diffuse, glossy, delta specular; NONE for "no
// lobe" (primary ray hits the emitter) and anything unclassifiable.
VKM_CONST LOBE_D = 0u;
VKM_CONST LOBE_G = 1u;
VKM_CONST LOBE_S = 2u;
VKM_CONST LOBE_NONE = 3u;
// A set of lobe classes (shaders/lobes.glsl): bit LOBE_x.
VKM_CONST LOBE_BIT_D = 1u << LOBE_D;
VKM_CONST LOBE_BIT_G = 1u << LOBE_G;
VKM_CONST LOBE_BIT_S = 1u << LOBE_S;

// Material types MAT_*: shared/materials.h, the material table (included at the end).

// Estimators (host Estimator values, docs/descriptor.md §1).
VKM_CONST EST_NEE = 0u;
VKM_CONST EST_MIS_RESTRICTED = 1u;
VKM_CONST EST_MIS = 2u;

// Rec. 709 luminance weights: LUM_R r + LUM_G g + LUM_B b (double in C++,
// float in GLSL).
VKM_REAL LUM_R = 0.2126;
VKM_REAL LUM_G = 0.7152;
VKM_REAL LUM_B = 0.0722;

// Triangle word w: bits 0..15 material, 16..29 emitter + 1 (0: none),
// bit 30: flat shading (use the geometric normal), bit 31: the vertices have the file's
// tangents (glTF's TANGENT, for the normal map): vertex i's is the vec4 at word
// i + GpuParams::tangent_word_offset of the vertex array, after every GpuVertex
// (host SceneArrays::tangents; xyz the tangent, w = +-1 the bitangent's sign).
VKM_CONST TRI_MATERIAL_MASK = 0xFFFFu;
VKM_CONST TRI_EMITTER_SHIFT = 16u;
VKM_CONST TRI_EMITTER_MASK = 0x3FFFu;
VKM_CONST TRI_FLAT_BIT = 0x40000000u;
VKM_CONST TRI_TANGENT_BIT = 0x80000000u;

// Render modes (GpuParams::mode).
VKM_CONST MODE_DIRECT_PREVIEW = 0u;  // provisional: emission + one NEE bounce
VKM_CONST MODE_PATH = 1u;            // the full estimator (docs/descriptor.md §1)

struct GpuVertex {
    vec4 position;  // xyz, w = u texture coordinate
    vec4 normal;    // xyz shading normal, w = v texture coordinate
};

// Texture slots of a material (texture index + 1, 0 = none), 16 bits each:
// header.z low = reflectance, header.z high = specular_reflectance,
// header.y high = specular_transmittance (header.y bit 0: twosided); 15 bits
// at header.y bit 1: the emission's (an emissive mesh's radiance times it).
VKM_CONST MAT_TEX_MASK = 0xFFFFu;
VKM_CONST MAT_TEX_SHIFT = 16u;
VKM_CONST MAT_EMISSION_TEX_SHIFT = 1u;
VKM_CONST MAT_EMISSION_TEX_MASK = 0x7FFFu;
// principled only: header.w >> MAT_TEX_SHIFT (16 bits above the distribution) is
// the slot of its parameter texture, glTF's metallicRoughnessTexture with its
// factors multiplied in: G the roughness, B the metallic, replacing model0.y
// and model0.x at each hit. Models that read header.w as their distribution
// never have one.
// blendbsdf (MAT_BLEND) only: header.w holds its components' material indices (the
// first's in the low 16 bits, the second's in the high: TRI_MATERIAL_MASK bounds both),
// header.z's low slot the weight's texture (its luminance at the hit), reflectance.x the
// constant weight, the probability of the second component.
VKM_CONST BLEND_MAX_DEPTH = 8u;  // blends nested in blends, at most (the loader refuses more)

// Texture table (3 uvec4 per texture): [0] first texel, width, height, kind
// | nearest << 8; [1], [2]: rows 0 and 1 of the 2D affine uv transform
// (floatBitsToUint of a, b, c: u' = a u + b v + c).
VKM_CONST TEX_WORDS = 3u;
VKM_CONST TEX_BITMAP = 0u;
VKM_CONST TEX_CHECKERBOARD = 1u;
VKM_CONST TEX_NEAREST_BIT = 0x100u;

struct GpuMaterial {
    uvec4 header;        // x: type, y: twosided | specular_transmittance texture << 16, z: texture slots (above), w: distribution
    vec4 reflectance;    // rgb, w: alpha_u
    vec4 specular_reflectance;    // rgb, w: alpha_v
    vec4 specular_transmittance;  // rgb, w: int_ior
    vec4 eta;            // rgb (conductor), w: ext_ior
    vec4 k;              // rgb (conductor), w: nonlinear (0/1)
    // The model's own block, read by the model's named parameter block in shaders/bsdf.glsl:
    // principled (Principled, principled_params): metallic, roughness, specular, spec_tint |
    // anisotropic, sheen, sheen_tint, clearcoat | clearcoat_gloss, spec_trans, eta, unused;
    // roughplastic (roughplastic_transmittance): its coat table, filled by roughplastic_prepare.
    vec4 model0;
    vec4 model1;
    vec4 model2;
    // Textures read at each hit in textured scenes only: x: low 16 bits the normal map's slot
    // (texture + 1, 0: none; tangent space, +x along dp/du, +y along n x dp/du; on triangles
    // with TRI_TANGENT_BIT dp/du is the file's tangent), high 16 bits
    // the bump map's (Mitsuba's bumpmap: a height texture); y: the bits of the one present's
    // scale (glTF normalTexture.scale: the map's x and y times it; bumpmap's scale: the
    // height's), z: the roughness
    // textures of roughconductor and roughdielectric (low 16 bits alpha_u's slot, high alpha_v's;
    // their luminance replaces reflectance.w and specular_reflectance.w), w: 1 = the normal
    // map's bitangent follows the uv layout's handedness (glTF), 0 = ns x t (Mitsuba).
    uvec4 frame_tex;
    // principled only, in textured scenes: the slots (texture + 1, 0: none; 16 bits each) of the
    // textured float parameters Mitsuba 3 allows besides metallic and roughness, each read at each
    // hit (the texture's luminance, which the loader stores in every channel) in place of the
    // constant: x: spec_tint | anisotropic << 16, y: sheen | sheen_tint << 16, z: clearcoat |
    // clearcoat_gloss << 16, w: spec_trans (`specular` and `eta` are scalars in Mitsuba 3).
    uvec4 param_tex;
};
VKM_CONST MATERIAL_WORDS = 11u;  // uvec4 words of a GpuMaterial

struct GpuEmitter {
    vec4 radiance;  // rgb, w: total area
    uvec4 info;     // x: mesh index, y: first light triangle, z: light triangle count
};

// One emissive triangle in the light-selection table: selection probability
// proportional to luminance(radiance) * area (power), docs/descriptor.md §3 "light selection
// proportional to power".
struct GpuLightTriangle {
    uvec4 info;  // x: triangle index, y: emitter index
    vec4 cdf;    // x: cdf up to and including this triangle, y: area, z: pdf_area (selection / area)
};

// Emitters at infinity (docs/descriptor.md §1, beyond the paper): at most one
// environment (Mitsuba's `constant` or lat-long `envmap`) and any number of
// directional lights. A light-table entry whose info.x is LIGHT_INFINITE is one
// of them: info.y = 0 the environment, 1 + i directional light i; its cdf.z is
// the emitter's selection probability (not per unit area).
VKM_CONST LIGHT_INFINITE = 0xFFFFFFFFu;
VKM_CONST ENV_NONE = 0u;
VKM_CONST ENV_CONSTANT = 1u;
VKM_CONST ENV_MAP = 2u;

// The environment array (BINDING_ENVIRONMENT): one GpuEnvironment (ENV_WORDS
// uvec4 words), then one GpuDirectional (2 words) per directional light.
// An ENV_MAP's texels follow the scene textures' in the texel array: row y of
// the map at map.y + y * width, each texel rgb = radiance, w = the cdf of its
// row up to and including it (1 at the row's end); then `height` texels whose
// x is the marginal cdf of the rows up to and including row y. The cdfs are
// of a piecewise-constant density over the pixels that bounds the bilinear
// radiance from above (shaders/environment.glsl).
VKM_CONST ENV_WORDS = 5u;
struct GpuEnvironment {
    vec4 radiance;  // rgb: the constant's radiance or the map's scale, w: the environment's selection probability
    vec4 to_world0;  // rows 0..2 of the rotation from the environment's frame (Mitsuba: +y up) to world
    vec4 to_world1;
    vec4 to_world2;
    uvec4 map;  // x: ENV_*, y: first texel of the map, z: width, w: height
};
struct GpuDirectional {
    vec4 direction;   // xyz: the unit direction the light travels (world), w: selection probability
    vec4 irradiance;  // rgb: irradiance on a surface facing the light, w: unused
};

// Flattened BVH node (depth-first): interior nodes have count == 0, their
// first child is the next node and `offset` is the second child; leaves hold
// `count` triangles starting at `offset` (in BVH triangle order).
struct GpuBvhNode {
    vec4 bmin;    // xyz, w: uintBitsToFloat(offset)
    vec4 bmax;    // xyz, w: uintBitsToFloat(count)
};

// One instance of a shape group (Mitsuba's shapegroup / instance), for the
// GPU kernel's two-level software BVH (shaders/trace_bvh_gpu.glsl): a
// top-level leaf entry whose first w holds INSTANCE_ENTRY_BIT | instance
// index sends the ray, in the group's space, down the group's own tree.
// Rows of affine 3x4 maps: x' = dot(row.xyz, x) + row.w.
struct GpuInstance {
    vec4 to_local[3];  // world -> the group's space
    vec4 to_world[3];  // the group's space -> world
    uvec4 info;        // x: the root node of the group's tree (GPU kernel BVH), y: the group,
                       // z: the group's first triangle in the scene arrays, w: 0
};
VKM_CONST INSTANCE_ENTRY_BIT = 0x80000000u;
VKM_CONST NO_INSTANCE = 0xFFFFFFFFu;

// The 4-wide tree the software traversal runs (host/engine/accel/bvh.hpp
// collapse_bvh4, shaders/trace_bvh.glsl), three RGBA32 texels a node: the
// binary tree above with children and grandchildren pulled up, so one node
// holds up to four child boxes, each quantized to 8 bits per bound against
// the node's box: on axis a, a child's bound is origin[a] + q * 2^(e[a] - 127)
// (q: a byte of q0/q1; e[a]: byte a of origin.w's bits), computed in float
// and rounded outwards by the encoder so the decoded box always contains the
// child. Byte k of each q word belongs to child k.
// Child k is described by a 4-bit code: BVH4_CODE_EMPTY (an unused slot),
// BVH4_CODE_INTERIOR, or 1 + its triangle count for a leaf (at most
// BVH4_MAX_LEAF triangles). Codes of children 0 and 1: bits 24..27 and 28..31
// of origin.w; of children 2 and 3: bits 28..31 of q1.z and q1.w. A node's
// interior children are consecutive nodes from first_node (q1.z's low 28
// bits) in child order, and its leaf children's triangles consecutive
// triangles from first_tri (q1.w's low 28 bits) in child order (build_bvh
// orders the triangles so). The traversal refers to a child as an interior
// node's index (count 0) or a leaf's first triangle | (triangle count <<
// BVH4_COUNT_SHIFT); BVH4_EMPTY none.
VKM_CONST BVH4_EMPTY = 0xFFFFFFFFu;
VKM_CONST BVH4_COUNT_SHIFT = 28u;
VKM_CONST BVH4_INDEX_MASK = 0x0FFFFFFFu;
VKM_CONST BVH4_CODE_EMPTY = 0u;
VKM_CONST BVH4_CODE_INTERIOR = 1u;
VKM_CONST BVH4_MAX_LEAF = 14u;
VKM_CONST BVH4_STACK_SIZE = 96u;  // >= 3 x the deepest chain of interior nodes (collapse_bvh4 checks)

// The path tracer's counters (pathtrace.comp with VKMECH_COUNTERS; `bench
// render --profile --counters`): the uints COUNTER_RAYS .. COUNTER_CLOCK_BACKWARDS
// below, then for each phase below its clock ticks summed over the
// invocations, 64-bit as (low, high) at COUNTER_CLOCK + 2 * phase.
VKM_CONST COUNTER_RAYS = 0u;             // traces
VKM_CONST COUNTER_NODES = 1u;            // interior nodes visited
VKM_CONST COUNTER_LEAVES = 2u;           // leaves visited
VKM_CONST COUNTER_TRIANGLES = 3u;        // triangles tested
VKM_CONST COUNTER_DEEPEST_STACK = 4u;    // the deepest traversal stack (a maximum, not a sum)
VKM_CONST COUNTER_WRAPPED = 5u;          // != 0: a 32-bit total wrapped in this batch
VKM_CONST COUNTER_CLOCK_BACKWARDS = 6u;  // intervals left out because the clock went backwards The phases nest: the traces and
// NEE lie inside PHASE_BUSY, the shadow trace inside PHASE_NEE, BUSY inside
// PHASE_PATH; CAMERA and PATH are separate intervals inside PHASE_SLOT.
VKM_CONST PHASE_CAMERA = 0u;   // sample setup: random numbers, camera ray, tallies zeroed
VKM_CONST PHASE_PRIMARY = 1u;  // the camera ray's closest-hit trace
VKM_CONST PHASE_BOUNCE = 2u;   // the closest-hit traces of later segments
VKM_CONST PHASE_SHADOW = 3u;   // NEE's shadow traces
VKM_CONST PHASE_NEE = 4u;      // NEE whole: light sample, BSDF evaluation, shadow trace, event
VKM_CONST PHASE_BUSY = 5u;     // path_sample until this invocation's path ends
VKM_CONST PHASE_PATH = 6u;     // path_sample whole: BUSY, then waiting for the longer paths of the SIMD vector or warp
VKM_CONST PHASE_SLOT = 7u;     // render_slot whole: every sample of the pixel and its write
VKM_CONST PHASE_COUNT = 8u;
VKM_CONST COUNTER_CLOCK = 8u;  // the buffer holds COUNTER_CLOCK + 2 * PHASE_COUNT uints
struct GpuBvh4Node {
    vec4 origin;  // xyz: the node box's lower corner; w: uintBitsToFloat(e_x | e_y << 8 | e_z << 16 | code0 << 24 | code1 << 28)
    uvec4 q0;     // lo_x, lo_y, lo_z, hi_x
    uvec4 q1;     // hi_y, hi_z, first_node | code2 << 28, first_tri | code3 << 28
};

struct GpuParams {  // one batch's uniforms (std140): named 4-byte scalars, four to a 16-byte row
    mat4 camera_to_world;
    float tan_half_fov_x;
    float tan_half_fov_y;
    float aperture_radius;       // 0: pinhole
    float focus_distance;        // thin lens: camera-space depth of the focus plane
    uint film_width;
    uint film_height;
    uint seed;
    uint batch_samples;          // samples per pixel in this batch
    uint first_sample;           // index of the batch's first sample (the RNG stream position)
    uint max_depth;
    uint rr_depth;               // Russian roulette from this depth
    uint mode;                   // MODE_PATH or MODE_DIRECT_PREVIEW
    uint light_triangle_count;   // entries of the light table (triangles, then lights at infinity)
    uint debug_pixel;            // pixel whose events are recorded
    uint debug_capacity;         // events the debug buffer holds (0: recording off)
    uint per_pixel_counts;       // 1: per-pixel sample counts (binding 15): pixel p takes samples [0, n(p)) only
    uint active_pixels;          // per-pixel counts: pixels still taking samples in this batch
    uint workgroup_stride;       // workgroup order stride (workgroup_stride(), coprime with the count)
    uint claimed_pixels;         // 1: each invocation takes pixel slots from a counter (binding 17)
    uint unused0;
    // SPEC_WINDOW (render --pixel-bounds): the film is the window of the full film that starts at
    // (window_x0, window_y0); camera rays and random streams are the full film's pixels'.
    uint window_x0;
    uint window_y0;
    uint full_width;
    uint full_height;
    // The camera's clip planes (Mitsuba's near_clip and far_clip, glTF's znear and zfar): camera
    // depths along its +Z axis; a camera ray is traced over the part of it between them
    // (shaders/camera.glsl).
    float near_clip;
    float far_clip;
    uint tangent_word_offset;    // the file's tangent of vertex i: word i + this of the vertex array (TRI_TANGENT_BIT)
    uint unused1;
};

// One recorded contribution event (the GPU debug mode): the inputs of the
// cascade and the bucket the shader chose, for checking against the C++
// mirror of docs/descriptor.md §2.
struct GpuDebugEvent {
    uvec4 label;   // x: n, y: end lobe, z: delta before end (0/1), w: bucket chosen by the shader
    vec4 energy;   // x: luminance energy, y: glossy before end (0/1), z: sample index, w: unused
};

// Per-pixel result of one batch. Welford moments within the batch
// (docs/architecture.md, "Stable numerics"); the host merges batches in double.
struct GpuPixelAccum {
    vec4 rgb;          // rgb sum, w: samples counted (finite)
    vec4 lum;          // x: mean luminance, y: M2 / 4^w (scaled Welford), z: non-finite samples, w: exponent
    vec4 side;         // luminance energy sums: x: glossy-touching events, y: sum(energy * depth)
                       // over n >= 1, z: energy over n >= 1, w: 0
    vec4 bucket_rgb[6];  // linear RGB sums of the buckets: float 3b + c (b < 7, c = R, G, B) of the
                         // 24, read with accum_bucket_rgb; floats 21..23: the RGB of `direct` events
                         // with a glossy end vertex (the direct-glossy variant only, else 0). Energies
                         // (luminance) are derived from these RGB sums on the host, in double.
};

// Ray-tracing test kernel (tracerays.comp): one ray in, one hit out.
struct GpuRay {
    vec4 origin;     // xyz, w: tmin
    vec4 direction;  // xyz, w: tmax
};
struct GpuHit {
    vec4 hit;        // x: t (or -1 for a miss), y: u, z: v, w: uintBitsToFloat(primitive)
};

#ifdef __cplusplus
}  // namespace vkmech::gpu
#endif

#include "shared/materials.h"

#ifdef __cplusplus
#undef VKM_CONST
#undef VKM_REAL
#endif

#endif
