#include "render_fixture.hpp"

#include "render/session.hpp"

#include <algorithm>
#include <cmath>

namespace vkmech::testing {

std::vector<double> pixel_values(const Frame& f) {
    std::vector<double> v;
    for (const PixelStats& p : f.pixels) {
        v.insert(v.end(), p.rgb_sum.begin(), p.rgb_sum.end());
        v.insert(v.end(), p.bucket_sum.begin(), p.bucket_sum.end());
    }
    return v;
}

double max_relative_difference(const std::vector<double>& a, const std::vector<double>& b) {
    double worst = 0.0;
    for (size_t i = 0; i < a.size() && i < b.size(); ++i)
        worst = std::max(worst, std::abs(a[i] - b[i]) / (std::abs(b[i]) + 1e-3));
    return worst;
}

Frame render_scene(vk::Context& ctx, const std::string& path, const RenderSetup& setup) {
    return render_scene(ctx, load_scene(path, setup.load), setup);
}

Frame render_scene(vk::Context& ctx, Scene scene, const RenderSetup& setup) {
    scene.camera.set_film_width(setup.res);
    auto session_of = [&](Scene sc) {
        if (!setup.bvh_arrays)
            return RenderSession(ctx, std::move(sc), setup.traversal, LightSelection::Uniform, setup.kernel);
        SceneArrays arrays = flatten_scene(sc, Traversal::Bvh);
        return RenderSession(ctx, std::move(sc), std::move(arrays), setup.traversal, setup.kernel);
    };
    RenderSession session = session_of(std::move(scene));
    Features f = setup.generic ? Features::generic(setup.estimator) : session.features(setup.estimator);
    Renderer r = session.renderer(f);
    RenderSpec spec;
    spec.spp = setup.spp;
    spec.seed = setup.seed;
    spec.batch_spp = setup.batch;
    spec.pixel_order = setup.pixel_order;
    spec.on_batch = setup.on_batch;
    spec.sample_counts = setup.sample_counts;
    return r.render(spec);
}

Renderer project_scene_renderer(vk::Context& ctx, const std::string& name, int width) {
    Scene scene = load_scene(std::string(VKMECH_SOURCE_DIR) + "/scenes/" + name + ".xml");
    scene.camera.set_film_width(width);
    RenderSession session(ctx, std::move(scene), Traversal::Bvh);
    return session.renderer(session.features());  // the renderer shares the session's scene
}

}  // namespace vkmech::testing
