#include "scene_fixtures.hpp"

#include <algorithm>
#include <filesystem>

namespace vkmech::testing {

std::vector<std::string> project_scene_paths() {
    std::vector<std::string> out;
    for (const auto& e : std::filesystem::directory_iterator(std::string(VKMECH_SOURCE_DIR) + "/scenes"))
        if (e.is_regular_file() && e.path().extension() == ".xml") out.push_back(e.path().string());
    std::sort(out.begin(), out.end());
    return out;
}

Scene quad_scene() {
    Scene s;
    s.source = "<quad_scene>";
    Material m;
    m.id = "white";
    s.materials.push_back(m);
    Mesh q;
    q.name = "quad";
    q.kind = ShapeKind::Rectangle;
    q.positions = {{-1, -1, 0}, {1, -1, 0}, {1, 1, 0}, {-1, 1, 0}};
    q.indices = {{0, 1, 2}, {0, 2, 3}};
    q.material = 0;
    s.meshes.push_back(q);
    s.camera.to_world = glm::mat4(1.0f);
    s.camera.to_world[3] = glm::vec4(0, 0, -3, 1);  // at z = -3 looking along +z
    s.camera.width = s.camera.height = 16;
    return s;
}

void add_square_lamp(Scene& s, const std::string& name, float x, float z, bool faces_minus_z, float radiance,
                     uint32_t material) {
    Mesh q;
    q.name = name;
    q.kind = ShapeKind::Rectangle;
    q.positions = {{x - 0.5f, -0.5f, z}, {x + 0.5f, -0.5f, z}, {x + 0.5f, 0.5f, z}, {x - 0.5f, 0.5f, z}};
    q.indices =
        faces_minus_z ? std::vector<glm::uvec3>{{0, 2, 1}, {0, 3, 2}} : std::vector<glm::uvec3>{{0, 1, 2}, {0, 2, 3}};
    q.material = material;
    q.emitter = static_cast<int>(s.emitters.size());
    s.meshes.push_back(q);
    AreaEmitter e;
    e.mesh = static_cast<int>(s.meshes.size()) - 1;
    e.radiance = glm::vec3(radiance);
    s.emitters.push_back(e);
}

std::vector<glm::vec3> graded_triangles(uint32_t max_count, float ratio, float z_slope) {
    std::vector<glm::vec3> pos;
    float s = 1.0f;
    for (uint32_t i = 0; i < max_count && s > 1e-30f; ++i, s *= ratio) {
        const glm::vec3 c(s, 0.3f * s, z_slope * s);
        for (glm::vec3 v : {glm::vec3(0, 0, 0), glm::vec3(0.1f, 0, 0), glm::vec3(0, 0.1f, 0.05f)})
            pos.push_back(c + s * v);
    }
    return pos;
}

std::string sphere_on_floor_xml(const std::string& bsdf) {
    return R"(<scene version="3.0.0">
  <integrator type="path"><integer name="max_depth" value="6"/></integrator>
  <sensor type="perspective"><float name="fov" value="40"/>
    <transform name="to_world"><lookat origin="0, -4, 1.5" target="0, 0, 0.5" up="0, 0, 1"/></transform>
    <film type="hdrfilm"><integer name="width" value="24"/><integer name="height" value="24"/></film></sensor>
  <shape type="rectangle"><transform name="to_world"><scale value="4"/></transform>
    <bsdf type="diffuse"><rgb name="reflectance" value="0.6, 0.5, 0.4"/></bsdf></shape>
  <shape type="sphere"><point name="center" value="0, 0, 0.8"/><float name="radius" value="0.8"/>
    )" + bsdf +
           R"(</shape>
  <shape type="rectangle"><transform name="to_world"><rotate x="1" angle="180"/><translate value="0, 0, 4"/></transform>
    <emitter type="area"><rgb name="radiance" value="8"/></emitter></shape>
</scene>
)";
}

}  // namespace vkmech::testing
