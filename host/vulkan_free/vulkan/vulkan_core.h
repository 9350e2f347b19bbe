// Stands first on the include path of the Vulkan-free libraries (vkmech_io,
// vkmech_scene, vkmech_accel, vkmech_frame) and of the analysis layer, in
// place of the real Vulkan header, so that the build refuses Vulkan there
// (docs/architecture.md, "The layers and their modules").
#error "Vulkan included from a Vulkan-free library (docs/architecture.md): Vulkan code belongs in vk/ or render/"
