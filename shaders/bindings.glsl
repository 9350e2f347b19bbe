// Descriptor bindings of every compute entry (mirrored in host/render/bindings.hpp).
#ifndef VKMECH_BINDINGS_GLSL
#define VKMECH_BINDINGS_GLSL
#define BINDING_PARAMS 0
#define BINDING_VERTICES 1
#define BINDING_TRIANGLES 2
#define BINDING_MATERIALS 3
#define BINDING_LIGHT_TRIS 4
#define BINDING_EMITTERS 5
#define BINDING_ACCUM 6
#define BINDING_TLAS 7
#define BINDING_BVH_NODES 8
#define BINDING_BVH_TRIS 9
#define BINDING_RAYS 10
#define BINDING_HITS 11
#define BINDING_TEXELS 12
#define BINDING_TEXTURES 13
#define BINDING_DEBUG 14
#define BINDING_SAMPLE_COUNTS 15
#endif
