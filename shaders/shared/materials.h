// The material table (docs/architecture.md, "Recipe: a BSDF"): every material model
// vkmech renders, in one place, for GLSL and C++. From it are derived
// - the type codes MAT_<NAME> (GpuMaterial.header.x) and the host's BsdfType;
// - the Mitsuba plugin name of each model (to_string(BsdfType), `vkmech check`);
// - the specialization features a model needs (Features::from_scene on the
//   host; the guards of the BSDF dispatch in shaders/bsdf.glsl);
// - the lobe classes each model can sample (shaders/lobes.glsl);
// - the dispatch itself: bsdf.glsl calls <name>_eval_pdf and <name>_sample of
//   every row.
// Written as X-macros, which both compilers expand (glslang supports ## pasting).
// Included by shared/types.h (after LOBE_BIT_*), which is what to include.
#ifndef VKMECH_SHARED_MATERIALS_H
#define VKMECH_SHARED_MATERIALS_H

// Material features: each is a boolean specialization constant FEATURE_<NAME>
// (shaders/features.glsl) that compiles a family of models in or out of a
// scene's pipeline (docs/architecture.md, "Simulate only what the scene calls
// for"). X(NAME, name, bit, spec_id): `name` is what Features::describe()
// prints; `spec_id` the constant_id (shared/bindings.h lists the others).
#define VKM_MATERIAL_FEATURES(X)              \
    X(DIELECTRIC, dielectric, 0u, 1u)         \
    X(ROUGH, rough, 1u, 2u)                   \
    X(PLASTIC, plastic, 2u, 3u)               \
    X(PRINCIPLED, principled, 3u, 4u)         \
    X(CONDUCTOR, conductor, 4u, 5u)           \
    X(ROUGHDIFFUSE, roughdiffuse, 5u, 12u)    \
    X(BLEND, blend, 6u, 19u)

// Material properties (the `flags` column below).
// MATF_ALBEDO: the model's colour is GpuMaterial.reflectance, which may be a
// texture (the caller looks the texture up and passes it as `albedo`).
// MATF_TRANSMISSIVE: the model sees both sides itself (no `twosided` mirroring).
// One model refines its row by its parameters: principled has its D lobe only
// while its diffuse weight is positive (shaders/lobes.glsl), and transmits
// only with spec_trans > 0 (bsdf_is_transmissive in shaders/bsdf.glsl).
#define VKM_MATF_ALBEDO 1u
#define VKM_MATF_TRANSMISSIVE 2u

// The models. X(code, NAME, Name, name, features, lobes, flags):
//   code      MAT_<NAME>, the value stored in GpuMaterial.header.x (never reuse one);
//   Name      the host's BsdfType::<Name>;
//   name      the Mitsuba plugin name, and the prefix of the model's functions in
//             bsdf.glsl: <name>_eval_pdf(m, albedo, wo, wi, pdf), <name>_sample(m, albedo, wo, u_lobe, u);
//   features  FEATURE_BIT_* the model needs compiled in (0: always);
//   lobes     LOBE_BIT_D/G/S it can sample (docs/descriptor.md §2); 0 for blendbsdf, which is
//             no BSDF of its own: each hit resolves it to one of its components (blend_resolve
//             in shaders/pathtrace.comp), whose lobes it then has;
//   flags     VKM_MATF_* above.
#define VKM_MATERIALS(X)                                                                                            \
    X(0u, DIFFUSE, Diffuse, diffuse, 0u, LOBE_BIT_D, VKM_MATF_ALBEDO)                                               \
    X(1u, PLASTIC, Plastic, plastic, FEATURE_BIT_PLASTIC, LOBE_BIT_S | LOBE_BIT_D, VKM_MATF_ALBEDO)                 \
    X(2u, ROUGHPLASTIC, RoughPlastic, roughplastic, FEATURE_BIT_PLASTIC | FEATURE_BIT_ROUGH,                        \
      LOBE_BIT_G | LOBE_BIT_D, VKM_MATF_ALBEDO)                                                                     \
    X(3u, CONDUCTOR, Conductor, conductor, FEATURE_BIT_CONDUCTOR, LOBE_BIT_S, 0u)                                   \
    X(4u, ROUGHCONDUCTOR, RoughConductor, roughconductor, FEATURE_BIT_CONDUCTOR | FEATURE_BIT_ROUGH, LOBE_BIT_G,    \
      0u)                                                                                                           \
    X(5u, DIELECTRIC, Dielectric, dielectric, FEATURE_BIT_DIELECTRIC, LOBE_BIT_S, VKM_MATF_TRANSMISSIVE)            \
    X(6u, ROUGHDIELECTRIC, RoughDielectric, roughdielectric, FEATURE_BIT_DIELECTRIC | FEATURE_BIT_ROUGH,            \
      LOBE_BIT_G, VKM_MATF_TRANSMISSIVE)                                                                            \
    X(7u, THINDIELECTRIC, ThinDielectric, thindielectric, FEATURE_BIT_DIELECTRIC, LOBE_BIT_S, VKM_MATF_TRANSMISSIVE) \
    X(8u, PRINCIPLED, Principled, principled, FEATURE_BIT_PRINCIPLED, LOBE_BIT_G | LOBE_BIT_D,                      \
      VKM_MATF_ALBEDO | VKM_MATF_TRANSMISSIVE)                                                                     \
    X(9u, ROUGHDIFFUSE, RoughDiffuse, roughdiffuse, FEATURE_BIT_ROUGHDIFFUSE, LOBE_BIT_G, VKM_MATF_ALBEDO)          \
    X(10u, BLEND, Blend, blendbsdf, FEATURE_BIT_BLEND, 0u, 0u)

#ifdef __cplusplus
namespace vkmech::gpu {
#endif

// FEATURE_BIT_<NAME> and SPEC_<NAME> of every material feature.
#define VKM_X(NAME, name, bit, spec_id)          \
    VKM_CONST FEATURE_BIT_##NAME = 1u << (bit); \
    VKM_CONST SPEC_##NAME = spec_id;
VKM_MATERIAL_FEATURES(VKM_X)
#undef VKM_X
#define VKM_X(NAME, name, bit, spec_id) | FEATURE_BIT_##NAME
VKM_CONST FEATURE_BITS_ALL = 0u VKM_MATERIAL_FEATURES(VKM_X);
#undef VKM_X

// MAT_<NAME> of every model, and MAT_COUNT (the codes are 0 .. MAT_COUNT - 1).
#define VKM_X(code, NAME, Name, name, features, lobes, flags) VKM_CONST MAT_##NAME = code;
VKM_MATERIALS(VKM_X)
#undef VKM_X
#define VKM_X(code, NAME, Name, name, features, lobes, flags) +1u
VKM_CONST MAT_COUNT = 0u VKM_MATERIALS(VKM_X);
#undef VKM_X

// The columns of the table by type code; 0 for a code not in the table.
#ifdef __cplusplus
#define VKM_TABLE_COLUMN(fn, column) \
    constexpr uint fn(uint type) {   \
        VKM_MATERIALS(column)        \
        return 0u;                   \
    }
#else
#define VKM_TABLE_COLUMN(fn, column) \
    uint fn(uint type) {             \
        VKM_MATERIALS(column)        \
        return 0u;                   \
    }
#endif
#define VKM_COLUMN_FEATURES(code, NAME, Name, name, features, lobes, flags) \
    if (type == (code)) return features;
#define VKM_COLUMN_LOBES(code, NAME, Name, name, features, lobes, flags) \
    if (type == (code)) return lobes;
#define VKM_COLUMN_FLAGS(code, NAME, Name, name, features, lobes, flags) \
    if (type == (code)) return flags;
VKM_TABLE_COLUMN(material_features, VKM_COLUMN_FEATURES)
VKM_TABLE_COLUMN(material_lobes, VKM_COLUMN_LOBES)
VKM_TABLE_COLUMN(material_flags, VKM_COLUMN_FLAGS)
#undef VKM_TABLE_COLUMN
#undef VKM_COLUMN_FEATURES
#undef VKM_COLUMN_LOBES
#undef VKM_COLUMN_FLAGS

#ifdef __cplusplus
}  // namespace vkmech::gpu
#endif

#endif
