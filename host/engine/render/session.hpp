// A scene loaded on one device: the Scene, its flattened arrays and the
// GpuScene, owned together. Everything that renders (the CLI, the adaptive
// driver, the studies, the benchmarks, the tests) starts from one:
//
//     RenderSession session(ctx, load_scene(path), Traversal::Bvh);
//     Renderer r = session.renderer(session.features(Estimator::Mis));
//     Frame f = r.render(spec);
//
// Renderers share the session's ownership of the scene, so a renderer stays
// valid after the session object is gone; only the vk::Context must outlive
// both (one context serves many sessions).
#pragma once

#include "render/features.hpp"
#include "render/gpu_scene.hpp"
#include "render/renderer.hpp"
#include "scene/scene.hpp"

#include <memory>

namespace vkmech {

struct SceneOnDevice {
    SceneOnDevice(const vk::Context& ctx, Scene scene, Traversal traversal, LightSelection selection,
                  vk::KernelClass kernel = vk::KernelClass::Auto);
    SceneOnDevice(const vk::Context& ctx, Scene scene, SceneArrays arrays, Traversal traversal,
                  vk::KernelClass kernel = vk::KernelClass::Auto);
    const vk::Context& ctx;
    const Scene scene;
    const SceneArrays arrays;  // flatten_scene(scene, traversal, ...): with a BVH only for Traversal::Bvh
    const GpuScene gpu;        // built from arrays with the traversal asked for
};

class RenderSession {
public:
    // Flattens the scene for the traversal (throws SceneError when it cannot
    // be rendered; only the software BVH builds a BVH) and uploads it. `traversal` must be resolved
    // (resolve_traversal), not Auto. `kernel`: the device-class kernel; Auto = the context's (vk::Context::kernel).
    RenderSession(const vk::Context& ctx, Scene scene, Traversal traversal,
                  LightSelection selection = LightSelection::Uniform, vk::KernelClass kernel = vk::KernelClass::Auto);
    // A scene already flattened for the traversal (flatten_scene(scene, traversal),
    // e.g. to digest it first).
    RenderSession(const vk::Context& ctx, Scene scene, SceneArrays arrays, Traversal traversal,
                  vk::KernelClass kernel = vk::KernelClass::Auto);

    const vk::Context& context() const { return data_->ctx; }
    const Scene& scene() const { return data_->scene; }
    const SceneArrays& arrays() const { return data_->arrays; }
    const GpuScene& gpu() const { return data_->gpu; }
    Traversal traversal() const { return data_->gpu.traversal(); }

    // The specialized pipeline this scene needs (Features::from_scene).
    Features features(Estimator estimator = Estimator::Nee, bool capture = true) const;
    // A renderer of this scene with `features` (a pipeline and a film).
    Renderer renderer(const Features& features) const;
    std::unique_ptr<Renderer> make_renderer(const Features& features) const;

    const std::shared_ptr<const SceneOnDevice>& shared() const { return data_; }

private:
    std::shared_ptr<const SceneOnDevice> data_;
};

}  // namespace vkmech
