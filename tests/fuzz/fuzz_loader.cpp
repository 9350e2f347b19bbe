// libFuzzer target for the scene loader: every input format vkmech reads,
// end to end through flattening (BVH build included), as `vkmech render`
// would see it before the GPU.
//
// Input: one selector byte, then the file's bytes.
//   selector % 7: 0 Mitsuba XML, 1 OBJ, 2 PLY, 3 Mitsuba serialized,
//                 4 glTF (.gltf), 5 glTF binary (.glb), 6 PNG texture
// XML is written into a copy of tests/data/loader, so the meshes, textures
// and includes its seeds refer to resolve. A mesh or PNG is written beside a
// fixed wrapper scene that references it, so the whole scene path runs.
//
// A SceneError is the loader's clear message for bad input: fine. Any other
// exception, a sanitizer report, a crash, a timeout (hang) or running out of
// the memory limit is a finding. tests/fuzz/run.sh builds the corpus and runs
// this target; docs/reliability.md gives the campaign's command and results.
#include "render/gpu_scene.hpp"
#include "scene/scene.hpp"

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <filesystem>
#include <fstream>
#include <string>

#include <unistd.h>

namespace fs = std::filesystem;

namespace {

fs::path g_dir;  // this process's scratch directory

void write_file(const fs::path& p, const uint8_t* data, size_t size) {
    std::ofstream f(p, std::ios::binary | std::ios::trunc);
    f.write(reinterpret_cast<const char*>(data), static_cast<std::streamsize>(size));
}

void write_text(const fs::path& p, const std::string& s) {
    write_file(p, reinterpret_cast<const uint8_t*>(s.data()), s.size());
}

// A small scene around one shape (or one textured quad) read from `file`.
std::string wrapper_scene(const std::string& shape) {
    return R"(<scene version="3.0.0">
  <sensor type="perspective">
    <float name="fov" value="40"/>
    <transform name="to_world"><lookat origin="0, 0, 4" target="0, 0, 0" up="0, 1, 0"/></transform>
    <film type="hdrfilm"><integer name="width" value="8"/><integer name="height" value="8"/></film>
  </sensor>
  <shape type="rectangle">
    <transform name="to_world"><translate z="3"/></transform>
    <emitter type="area"><rgb name="radiance" value="1, 1, 1"/></emitter>
  </shape>
)" + shape +
           "\n</scene>\n";
}

void write_wrappers() {
    const char* kinds[] = {"obj", "ply", "serialized"};
    for (const char* k : kinds)
        write_text(g_dir / (std::string("mesh_") + k + ".xml"),
                   wrapper_scene(std::string("  <shape type=\"") + k + "\"><string name=\"filename\" value=\"fuzz." +
                                 k + "\"/><bsdf type=\"diffuse\"/></shape>"));
    write_text(g_dir / "texture.xml",
               wrapper_scene("  <shape type=\"rectangle\"><bsdf type=\"diffuse\"><texture type=\"bitmap\" "
                             "name=\"reflectance\"><string name=\"filename\" value=\"fuzz.png\"/></texture></bsdf>"
                             "</shape>"));
}

}  // namespace

extern "C" int LLVMFuzzerInitialize(int*, char***) {
    g_dir = fs::temp_directory_path() / ("vkmech_fuzz_" + std::to_string(::getpid()));
    fs::remove_all(g_dir);
    fs::create_directories(g_dir);
    // The seeds' relative references (meshes/, inc/, checker2x2.png) resolve here.
    fs::copy(fs::path(VKMECH_TEST_DATA) / "loader", g_dir / "loader", fs::copy_options::recursive);
    write_wrappers();
    std::atexit([] {
        std::error_code ec;
        fs::remove_all(g_dir, ec);
    });
    return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    if (size < 1) return 0;
    const uint8_t* body = data + 1;
    size_t n = size - 1;
    std::string scene_path;
    switch (data[0] % 7) {
        case 0:
            scene_path = (g_dir / "loader" / "fuzz.xml").string();
            write_file(scene_path, body, n);
            break;
        case 1:
            write_file(g_dir / "fuzz.obj", body, n);
            scene_path = (g_dir / "mesh_obj.xml").string();
            break;
        case 2:
            write_file(g_dir / "fuzz.ply", body, n);
            scene_path = (g_dir / "mesh_ply.xml").string();
            break;
        case 3:
            write_file(g_dir / "fuzz.serialized", body, n);
            scene_path = (g_dir / "mesh_serialized.xml").string();
            break;
        case 4:
            scene_path = (g_dir / "fuzz.gltf").string();
            write_file(scene_path, body, n);
            break;
        case 5:
            scene_path = (g_dir / "fuzz.glb").string();
            write_file(scene_path, body, n);
            break;
        default:
            write_file(g_dir / "fuzz.png", body, n);
            scene_path = (g_dir / "texture.xml").string();
            break;
    }
    vkmech::LoadOptions options;
    options.substitute_unsupported = (n % 2) == 1;  // both the strict and the substituting paths
    // A budget small enough that a legitimately big scene fits libFuzzer's
    // time and memory limits; the budget check itself is what is fuzzed.
    options.max_triangles = 2'000'000;
    try {
        vkmech::Scene scene = vkmech::load_scene(scene_path, options);
        vkmech::SceneArrays arrays = vkmech::flatten_scene(scene, vkmech::Traversal::Bvh);
        (void)arrays;
    } catch (const vkmech::SceneError&) {
        // The loader's clear message for bad input.
    } catch (const std::exception& e) {
        std::fprintf(stderr, "fuzz_loader: not a SceneError: %s\n", e.what());
        std::abort();
    }
    return 0;
}
