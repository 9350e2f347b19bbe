#include "render/session.hpp"
#include "io/invariant.hpp"

#include <stdexcept>
#include <string>

namespace vkmech {

SceneOnDevice::SceneOnDevice(const vk::Context& c, Scene s, Traversal traversal, LightSelection selection,
                             vk::KernelClass kernel)
    : ctx(c),
      scene(std::move(s)),
      arrays(flatten_scene(scene, resolve_traversal(c, traversal), selection)),
      gpu(c, arrays, traversal, kernel) {}

SceneOnDevice::SceneOnDevice(const vk::Context& c, Scene s, SceneArrays a, Traversal traversal, vk::KernelClass kernel)
    : ctx(c), scene(std::move(s)), arrays(std::move(a)), gpu(c, arrays, traversal, kernel) {
    VKM_ASSERT(arrays.triangle_mesh.size() == scene.triangle_count(),
               "RenderSession: the scene arrays (" + std::to_string(arrays.triangle_mesh.size()) +
                   " triangles) do not belong to the scene (" + std::to_string(scene.triangle_count()) + " triangles)");
}

RenderSession::RenderSession(const vk::Context& ctx, Scene scene, Traversal traversal, LightSelection selection,
                             vk::KernelClass kernel)
    : data_(std::make_shared<const SceneOnDevice>(ctx, std::move(scene), traversal, selection, kernel)) {}

RenderSession::RenderSession(const vk::Context& ctx, Scene scene, SceneArrays arrays, Traversal traversal,
                             vk::KernelClass kernel)
    : data_(std::make_shared<const SceneOnDevice>(ctx, std::move(scene), std::move(arrays), traversal, kernel)) {}

Features RenderSession::features(Estimator estimator, bool capture) const {
    return Features::from_scene(data_->scene, estimator, capture);
}

Renderer RenderSession::renderer(const Features& features) const { return Renderer(data_, features); }

std::unique_ptr<Renderer> RenderSession::make_renderer(const Features& features) const {
    return std::make_unique<Renderer>(data_, features);
}

}  // namespace vkmech
