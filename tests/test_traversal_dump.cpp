// `vkmech bench traversal --dump`: the files ci/bench_embree.cpp reads hold
// exactly the triangles, rays and hits they were made from.
#include "temp_dir.hpp"

#include "render/traversal_dump.hpp"

#include <doctest/doctest.h>

#include <bit>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <stdexcept>

using namespace vkmech;

namespace {

SceneArrays two_triangles() {
    SceneArrays a;
    a.tri_positions = {glm::vec4(0, 0, 0, 0), glm::vec4(1, 0, 0, 0), glm::vec4(0, 1, 0, 0),
                       glm::vec4(0, 0, 2, 0), glm::vec4(1, 0, 2, 0), glm::vec4(0, 1, 2.5f, 0)};
    return a;
}

gpu::GpuRay ray(glm::vec3 o, glm::vec3 d) {
    gpu::GpuRay r;
    r.origin = glm::vec4(o, 0.0f);
    r.direction = glm::vec4(d, 1e30f);
    return r;
}

}  // namespace

TEST_CASE("traversal dump: triangles rays and hits read back bit for bit") {
    testing::TempDir dir("trav_dump");
    std::vector<gpu::GpuRay> rays = {ray({0.2f, 0.2f, -1}, {0, 0, 1}), ray({5, 5, 5}, {1, 0, 0})};
    std::vector<gpu::GpuHit> hits(2);
    hits[0].hit = glm::vec4(1.0f, 0.2f, 0.2f, std::bit_cast<float>(1u));
    hits[1].hit = glm::vec4(-1.0f, 0.0f, 0.0f, std::bit_cast<float>(0xFFFFFFFFu));
    TraversalDump d = make_traversal_dump(two_triangles(), rays, hits);
    CHECK(d.triangle_count() == 2);
    CHECK(d.triangles[9 + 8] == 2.5f);  // second triangle, v2.z
    TraversalDumpInfo info;
    info.device = "llvmpipe \"test\"";
    info.seed = 1;
    info.bvh_rays_per_second = 1.5e6;
    info.bvh_per_invocation_rays_per_second = 1.25e6;
    write_traversal_dump(dir.path / "sub", "two", d, info);

    TraversalDump back = read_traversal_dump(dir.path / "sub", "two");
    REQUIRE(back.triangles.size() == 18);
    CHECK(std::memcmp(back.triangles.data(), d.triangles.data(), 18 * sizeof(float)) == 0);
    REQUIRE(back.rays.size() == 2);
    CHECK(std::memcmp(back.rays.data(), rays.data(), 2 * sizeof(gpu::GpuRay)) == 0);
    REQUIRE(back.hits.size() == 2);
    CHECK(back.hits[0].t == 1.0f);
    CHECK(back.hits[0].triangle == 1u);
    CHECK(back.hits[1].t == -1.0f);
    CHECK(back.hits[1].triangle == 0xFFFFFFFFu);
    CHECK(std::filesystem::file_size(dir.path / "sub" / "two.rays.bin") == 2 * 32);
    CHECK(std::filesystem::file_size(dir.path / "sub" / "two.hits.bin") == 2 * 8);

    std::string json = testing::read_text(dir.path / "sub" / "two.json");
    CHECK(json.find("\"triangles\": 2,") != std::string::npos);
    CHECK(json.find("\"rays\": 2,") != std::string::npos);
    CHECK(json.find("\"bvh_rays_per_second\": 1.5e+06,") != std::string::npos);
    CHECK(json.find("\"bvh_per_invocation_rays_per_second\": 1.25e+06,") != std::string::npos);
    CHECK(json.find("\"rayquery_rays_per_second\": null") != std::string::npos);
    CHECK(json.find("llvmpipe \\\"test\\\"") != std::string::npos);
}

TEST_CASE("traversal dump: truncated or missing files are refused") {
    testing::TempDir dir("trav_dump_bad");
    std::vector<gpu::GpuRay> rays = {ray({0, 0, -1}, {0, 0, 1})};
    std::vector<gpu::GpuHit> hits(1);
    CHECK_THROWS_AS(make_traversal_dump(two_triangles(), rays, {}), std::runtime_error);
    write_traversal_dump(dir.path, "one", make_traversal_dump(two_triangles(), rays, hits), TraversalDumpInfo{});
    CHECK_THROWS_AS(read_traversal_dump(dir.path, "absent"), std::runtime_error);
    std::filesystem::resize_file(dir.path / "one.rays.bin", 31);
    CHECK_THROWS_AS(read_traversal_dump(dir.path, "one"), std::runtime_error);
    std::filesystem::resize_file(dir.path / "one.rays.bin", 64);  // two rays, one hit
    CHECK_THROWS_AS(read_traversal_dump(dir.path, "one"), std::runtime_error);
}
