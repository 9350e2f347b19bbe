// The on-disk pipeline cache (vk/pipeline_cache.hpp): header validation on
// hand-made bytes (no device); on the device, a saved file is loaded by the
// next context, and a corrupted file or an unusable directory never stops a
// render. Every test uses its own directory, never the user's cache.
#include "gpu_fixture.hpp"
#include "render/shader_modules.hpp"
#include "render_fixture.hpp"
#include "shared/bindings.h"
#include "temp_dir.hpp"
#include "vk/pipeline.hpp"
#include "vk/pipeline_cache.hpp"

#include <doctest/doctest.h>

#include <sys/wait.h>
#include <unistd.h>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>

namespace fs = std::filesystem;
using namespace vkmech;
namespace vkc = vkmech::vk;  // `vk` alone is Vulkan-Hpp's namespace

namespace {

struct TempDir : vkmech::testing::TempDir {
    explicit TempDir(const std::string& tag) : vkmech::testing::TempDir("pcache_" + tag) {}
};

vkc::PipelineCacheIdentity test_identity() {
    vkc::PipelineCacheIdentity id;
    id.vendor_id = 0x10de;
    id.device_id = 0x2330;
    for (size_t i = 0; i < id.uuid.size(); ++i) id.uuid[i] = static_cast<uint8_t>(0xa0 + i);
    return id;
}

void put_le32(std::vector<uint8_t>& b, size_t at, uint32_t v) {
    for (int k = 0; k < 4; ++k) b[at + k] = static_cast<uint8_t>(v >> (8 * k));
}

// A VkPipelineCacheHeaderVersionOne for `id`, then `payload` bytes.
std::vector<uint8_t> make_blob(const vkc::PipelineCacheIdentity& id, size_t payload = 64) {
    std::vector<uint8_t> b(32 + payload, 0x5a);
    put_le32(b, 0, 32);
    put_le32(b, 4, VK_PIPELINE_CACHE_HEADER_VERSION_ONE);
    put_le32(b, 8, id.vendor_id);
    put_le32(b, 12, id.device_id);
    std::memcpy(b.data() + 16, id.uuid.data(), id.uuid.size());
    return b;
}

vkc::PipelineCacheIdentity device_identity(const vkc::Context& ctx) {
    auto props = ctx.physical().getProperties();
    vkc::PipelineCacheIdentity id;
    id.vendor_id = props.vendorID;
    id.device_id = props.deviceID;
    std::memcpy(id.uuid.data(), props.pipelineCacheUUID.data(), id.uuid.size());
    return id;
}

fs::path cache_file(const vkc::Context& ctx, const fs::path& dir) {
    return dir / vkc::pipeline_cache_file_name(device_identity(ctx), ctx.physical().getProperties().driverVersion);
}

std::vector<uint8_t> read_bytes(const fs::path& p) {
    std::ifstream in(p, std::ios::binary);
    return std::vector<uint8_t>(std::istreambuf_iterator<char>(in), {});
}

void write_bytes(const fs::path& p, const std::vector<uint8_t>& b) {
    std::ofstream(p, std::ios::binary)
        .write(reinterpret_cast<const char*>(b.data()), static_cast<std::streamsize>(b.size()));
}

// A context of its own, caching in `dir` ("off": none), validated like the shared one.
std::unique_ptr<vkc::Context> context_with_cache(const std::string& dir) {
    vkc::ContextOptions o;
    o.validation = true;
    o.pipeline_cache_dir = dir;
    return std::make_unique<vkc::Context>(o);
}

// The ray-casting shader's pipeline (small; creating it needs no scene).
std::unique_ptr<vkc::ComputePipeline> tracerays_pipeline(const vkc::Context& ctx) {
    using DT = ::vk::DescriptorType;
    using namespace gpu;
    std::vector<vkc::BindingDesc> bindings = {{BINDING_RAYS, DT::eStorageBuffer}, {BINDING_HITS, DT::eStorageBuffer}};
    for (const auto& b : traversal_bindings(Traversal::Bvh, ctx.kernel())) bindings.push_back(b);
    return std::make_unique<vkc::ComputePipeline>(ctx, tracerays_spirv(Traversal::Bvh, ctx.kernel()), bindings,
                                                  kTraceraysPushBytes);
}

bool renders_finite_image(vkc::Context& ctx) {
    testing::RenderSetup setup;
    setup.res = 16;
    setup.spp = 2;
    Frame f = testing::render_scene(ctx, std::string(VKMECH_SOURCE_DIR) + "/scenes/cubes_dof.xml", setup);
    if (f.pixels.size() != 16u * static_cast<size_t>(f.height) || f.samples == 0) return false;
    for (float v : f.rgb_mean())
        if (!std::isfinite(v)) return false;
    return true;
}

}  // namespace

TEST_CASE("pipeline cache: a header written for this device is accepted") {
    const auto id = test_identity();
    CHECK(vkc::check_pipeline_cache_header(make_blob(id), id).empty());
    CHECK(vkc::check_pipeline_cache_header(make_blob(id, 0), id).empty());  // header only: an empty cache
    // A longer header (headerSize > 32) is allowed by the spec.
    auto longer = make_blob(id, 16);
    put_le32(longer, 0, 40);
    CHECK(vkc::check_pipeline_cache_header(longer, id).empty());
}

TEST_CASE("pipeline cache: foreign, truncated, empty and garbage headers are rejected") {
    const auto id = test_identity();
    auto reason = [&](const std::vector<uint8_t>& b) { return vkc::check_pipeline_cache_header(b, id); };

    auto uuid = make_blob(id);
    uuid[16 + 5] ^= 0xff;
    CHECK(reason(uuid).find("pipelineCacheUUID") != std::string::npos);

    auto vendor = make_blob(id);
    put_le32(vendor, 8, 0x1002);
    CHECK(reason(vendor).find("vendor") != std::string::npos);

    auto device = make_blob(id);
    put_le32(device, 12, 0x1234);
    CHECK(reason(device).find("device") != std::string::npos);

    auto version = make_blob(id);
    put_le32(version, 4, 2);
    CHECK(reason(version).find("version") != std::string::npos);

    CHECK(reason({}).find("empty") != std::string::npos);
    auto truncated = make_blob(id);
    truncated.resize(20);
    CHECK(reason(truncated).find("truncated") != std::string::npos);

    auto short_len = make_blob(id);
    put_le32(short_len, 0, 16);  // shorter than the fields it must hold
    CHECK(!reason(short_len).empty());
    auto long_len = make_blob(id, 8);
    put_le32(long_len, 0, 1000);  // past the end of the data
    CHECK(!reason(long_len).empty());

    std::vector<uint8_t> garbage(4096);
    for (size_t i = 0; i < garbage.size(); ++i) garbage[i] = static_cast<uint8_t>(i * 131 + 7);
    CHECK(!reason(garbage).empty());
    std::string text = "not a pipeline cache, just some text that is long enough to hold a header";
    CHECK(!reason(std::vector<uint8_t>(text.begin(), text.end())).empty());
}

TEST_CASE("pipeline cache: the file name and the default directory") {
    const auto id = test_identity();
    CHECK(vkc::pipeline_cache_file_name(id, 0x1234) == "pipelines-10de-2330-1234-a0a1a2a3a4a5a6a7a8a9aaabacadaeaf.bin");
    // ctest sets VKMECH_CACHE_DIR (CMakeLists.txt); the variable wins when set.
    if (const char* d = std::getenv("VKMECH_CACHE_DIR"); d && *d) CHECK(vkc::default_pipeline_cache_dir() == d);
}

TEST_SUITE("gpu") {
    TEST_CASE("pipeline cache: a saved cache file is loaded by the next run and pipelines are created from it") {
        VKMECH_REQUIRE_GPU(shared);
        TempDir dir("reuse");
        size_t saved = 0;
        {
            auto ctx = context_with_cache(dir.path.string());
            CHECK(ctx->pipeline_cache().enabled());
            CHECK(ctx->pipeline_cache().loaded_bytes() == 0);
            auto pipe = tracerays_pipeline(*ctx);
            CHECK(ctx->pipeline_cache().stats().created == 1);
            // Saved right after creation, not only at exit.
            const fs::path file = cache_file(*ctx, dir.path);
            REQUIRE(fs::exists(file));
            auto bytes = read_bytes(file);
            CHECK(vkc::check_pipeline_cache_header(bytes, device_identity(*ctx)).empty());
            saved = bytes.size();
            CHECK(ctx->validation_messages() == 0);
        }
        auto ctx = context_with_cache(dir.path.string());
        CHECK(ctx->pipeline_cache().loaded_bytes() == saved);
        auto pipe = tracerays_pipeline(*ctx);
        CHECK(ctx->pipeline_cache().stats().created == 1);
        CHECK(ctx->validation_messages() == 0);
        // No temporary file is left behind.
        for (const auto& e : fs::directory_iterator(dir.path))
            CHECK(e.path().filename().string().find(".tmp") == std::string::npos);
    }

    TEST_CASE(
        "pipeline cache: a pipeline made again from the same inputs in one process is reused, not compiled "
        "again - and renders the same image") {
        VKMECH_REQUIRE_GPU(shared);
        TempDir dir("kept");
        auto ctx = context_with_cache(dir.path.string());  // validation on: a shared layout must be compatible
        auto a = tracerays_pipeline(*ctx);
        const vkc::PipelineStats first = ctx->pipeline_cache().stats();
        CHECK(first.created == 1);
        CHECK(first.reused == 0);
        auto b = tracerays_pipeline(*ctx);
        CHECK(ctx->pipeline_cache().stats().created == 1);  // nothing created, nothing compiled
        CHECK(ctx->pipeline_cache().stats().reused == 1);
        CHECK(ctx->pipeline_cache().stats().seconds == first.seconds);
        CHECK(vkc::pipeline_cache_outcome(ctx->pipeline_cache().stats() - first, true) == "reused in this process");
        // Whole renders: the second render of a scene takes the first's pipelines; another estimator's
        // specialization is a pipeline of its own, compiled.
        testing::RenderSetup setup;
        setup.res = 16;
        setup.spp = 4;
        const std::string scene = std::string(VKMECH_SOURCE_DIR) + "/scenes/glass_caustic.xml";
        const Frame f1 = testing::render_scene(*ctx, scene, setup);
        const vkc::PipelineStats after_one = ctx->pipeline_cache().stats();
        const Frame f2 = testing::render_scene(*ctx, scene, setup);
        const vkc::PipelineStats after_two = ctx->pipeline_cache().stats();
        CHECK(after_one.created > first.created);
        CHECK(after_two.created == after_one.created);  // every pipeline of the second render reused
        CHECK(after_two.reused > after_one.reused);
        REQUIRE(f1.pixels.size() == f2.pixels.size());
        CHECK(std::memcmp(f1.pixels.data(), f2.pixels.data(), f1.pixels.size() * sizeof(f1.pixels[0])) == 0);
        setup.estimator = Estimator::Mis;
        testing::render_scene(*ctx, scene, setup);
        const vkc::PipelineStats after_mis = ctx->pipeline_cache().stats();
        CHECK(after_mis.created > after_two.created);  // the MIS specialization compiled
        CHECK(ctx->validation_messages() == 0);
    }

    TEST_CASE("pipeline cache: a corrupted cache file is ignored and rendering still works") {
        VKMECH_REQUIRE_GPU(shared);
        TempDir dir("corrupt");
        const fs::path file = cache_file(*shared, dir.path);
        std::vector<uint8_t> garbage(1000);
        for (size_t i = 0; i < garbage.size(); ++i) garbage[i] = static_cast<uint8_t>(i * 37 + 11);
        // A right header over a garbage body reaches the driver, which must cope.
        auto good_header = make_blob(device_identity(*shared), 500);
        auto foreign = make_blob(test_identity());
        auto truncated = make_blob(device_identity(*shared));
        truncated.resize(17);
        for (const auto* bytes :
             {&garbage, &good_header, &foreign, &truncated, static_cast<std::vector<uint8_t>*>(nullptr)}) {
            CAPTURE(bytes ? bytes->size() : 0);
            write_bytes(file, bytes ? *bytes : std::vector<uint8_t>{});  // nullptr: zero length
            auto ctx = context_with_cache(dir.path.string());
            // Rendering compiles the big shader: once, on the most dangerous
            // file (the driver gets its body); the others create the small one.
            if (bytes == &good_header) {
                CHECK(renders_finite_image(*ctx));
            } else {
                CHECK(ctx->pipeline_cache().loaded_bytes() == 0);
                auto pipe = tracerays_pipeline(*ctx);
            }
            CHECK(ctx->pipeline_cache().stats().created == 1);
            // Headers we refuse never reach the driver, so nothing is reported.
            // A right header over a garbage body does: the NVIDIA driver refuses
            // it and the validation layer says "unable to load pipeline cache
            // entry" (seen on an H100, docs/gpu.md) before vkmech starts empty;
            // lavapipe ignores the body silently. Either way rendering works.
            if (bytes != &good_header) CHECK(ctx->validation_messages() == 0);
            // The bad file was replaced by a valid one.
            CHECK(vkc::check_pipeline_cache_header(read_bytes(file), device_identity(*ctx)).empty());
        }
    }

    TEST_CASE("pipeline cache: an unusable cache directory does not make rendering fail") {
        VKMECH_REQUIRE_GPU(shared);
        TempDir dir("unwritable");
        // Cannot be created (its parent is a file), whatever our privileges.
        write_bytes(dir.path / "file", {1, 2, 3});
        {
            auto ctx = context_with_cache((dir.path / "file" / "cache").string());
            CHECK(renders_finite_image(*ctx));
        }
        // Exists, but the cache file's name is taken by a directory: reading
        // and the final rename both fail.
        fs::create_directories(cache_file(*shared, dir.path / "taken"));
        {
            auto ctx = context_with_cache((dir.path / "taken").string());
            CHECK(ctx->pipeline_cache().loaded_bytes() == 0);
            CHECK(renders_finite_image(*ctx));
            CHECK(fs::is_directory(cache_file(*ctx, dir.path / "taken")));
        }
        // Off: no VkPipelineCache at all, pipelines still timed.
        auto ctx = context_with_cache("off");
        CHECK_FALSE(ctx->pipeline_cache().enabled());
        CHECK(renders_finite_image(*ctx));
        CHECK(ctx->pipeline_cache().stats().created == 1);
        CHECK(vkc::pipeline_cache_outcome(ctx->pipeline_cache().stats(), false) == "cache off");
    }

    TEST_CASE("pipeline cache: vkmech render reports pipeline creation apart from the render time") {
        VKMECH_REQUIRE_GPU(shared);
        TempDir dir("cli");
        const std::string log = (dir.path / "log.txt").string();
        const std::string cmd = std::string(VKMECH_CLI) + " --scene cubes_dof --spp 2 --res 16 --out " +
                                (dir.path / "out").string() + " --pipeline-cache " + (dir.path / "cache").string() +
                                " > " + log + " 2>&1";
        for (int run = 0; run < 2; ++run) {
            CAPTURE(run);
            int status = std::system(cmd.c_str());
            std::stringstream out, json;
            out << std::ifstream(log).rdbuf();
            INFO(out.str());
            REQUIRE((WIFEXITED(status) && WEXITSTATUS(status) == 0));
            CHECK(out.str().find("pipeline creation: ") != std::string::npos);
            json << std::ifstream(dir.path / "out" / "cubes_dof.json").rdbuf();
            CHECK(json.str().find("\"pipeline_creation_seconds\": ") != std::string::npos);
            CHECK(json.str().find("\"pipeline_cache\": \"cache ") != std::string::npos);
        }
        CHECK(fs::exists(cache_file(*shared, dir.path / "cache")));
    }
}
