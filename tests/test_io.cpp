// Image output layer: multi-channel EXR, PNG previews, atomic writes.
#include "io/atomic_file.hpp"
#include "io/exr.hpp"
#include "io/invariant.hpp"
#include "io/png.hpp"
#include "temp_dir.hpp"

#include <doctest/doctest.h>

// The stb_image implementation is compiled into the core library
// (host/engine/scene/image_texture.cpp); only the declarations are needed here.
#include <stb/stb_image.h>

#include <OpenEXR/ImfChannelList.h>
#include <OpenEXR/ImfHeader.h>
#include <OpenEXR/ImfInputFile.h>

#include <bit>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include <unistd.h>

namespace fs = std::filesystem;

namespace {

struct TempDir : vkmech::testing::TempDir {
    explicit TempDir(const std::string& tag) : vkmech::testing::TempDir("io_" + tag) {}
};

size_t count_temp_files(const fs::path& dir) {
    size_t n = 0;
    for (const auto& e : fs::recursive_directory_iterator(dir))
        if (e.path().filename().string().find(".tmp-") != std::string::npos) ++n;
    return n;
}

std::string slurp(const fs::path& p) {
    std::ifstream f(p, std::ios::binary);
    std::ostringstream s;
    s << f.rdbuf();
    return s.str();
}

// A path whose parent directory cannot be created (mkdir under /proc fails,
// also for root).
const std::string kUncreatable = "/proc/vkmech_no_such_dir/sub/out";

}  // namespace

TEST_CASE("io: EXR round-trip of named - layered channels keeps order and exact values") {
    TempDir tmp("exr");
    const int w = 7, h = 5;
    const size_t n = static_cast<size_t>(w) * h;
    // Deliberately not in alphabetical order; dotted names form layers.
    const std::vector<std::string> names = {
        "R",         "G",      "B",           "bucket.direct", "bucket.delta", "bucket.glossy", "bucket.diffuse",
        "dominant",  "purity", "frac.direct", "frac.delta",    "lum_var",      "lum_mean",      "spp",
        "nonfinite", "depth"};
    REQUIRE(names.size() >= 12);
    const float special[] = {0.0f,
                             -0.0f,
                             1.0f,
                             -3.5f,
                             std::numeric_limits<float>::min(),
                             std::numeric_limits<float>::denorm_min(),
                             std::numeric_limits<float>::max(),
                             std::numeric_limits<float>::infinity(),
                             std::numeric_limits<float>::quiet_NaN(),
                             0.1f,
                             1e-30f,
                             12345.678f};
    std::vector<vkmech::ExrChannel> ch;
    for (size_t c = 0; c < names.size(); ++c) {
        vkmech::ExrChannel e{names[c], std::vector<float>(n), false};
        for (size_t i = 0; i < n; ++i)
            e.data[i] = (i % 4 == 0) ? special[(i + c) % std::size(special)]
                                     : std::sin(0.37f * static_cast<float>(i) + static_cast<float>(c)) * 100.0f;
        ch.push_back(std::move(e));
    }
    // Two half channels: one with exactly representable values, one general.
    vkmech::ExrChannel hx{"half.exact", std::vector<float>(n), true};
    vkmech::ExrChannel hg{"half.general", std::vector<float>(n), true};
    for (size_t i = 0; i < n; ++i) {
        hx.data[i] = static_cast<float>(i) * 0.25f - 2.0f;  // multiples of 1/4 below 2048: exact in half
        hg.data[i] = 0.001f + 3.7f * static_cast<float>(i);
    }
    ch.insert(ch.begin() + 5, hx);
    ch.push_back(hg);

    const std::string path = (tmp.path / "out.exr").string();
    vkmech::write_exr_layers(path, w, h, ch);
    CHECK(count_temp_files(tmp.path) == 0);

    const vkmech::ExrImage img = vkmech::read_exr_channels(path);
    CHECK(img.width == w);
    CHECK(img.height == h);
    REQUIRE(img.channels.size() == ch.size());
    REQUIRE(img.order.size() == ch.size());
    for (size_t c = 0; c < ch.size(); ++c) CHECK(img.order[c] == ch[c].name);
    CHECK(img.half_channels == std::set<std::string>{"half.exact", "half.general"});

    for (const auto& e : ch) {
        CAPTURE(e.name);
        REQUIRE(img.channels.count(e.name) == 1);
        const std::vector<float>& got = img.channels.at(e.name);
        REQUIRE(got.size() == n);
        if (!e.half) {
            // 32-bit channels are bit-exact (NaN, -0, denormals included).
            size_t mismatches = 0;
            for (size_t i = 0; i < n; ++i)
                mismatches += std::bit_cast<uint32_t>(got[i]) != std::bit_cast<uint32_t>(e.data[i]);
            CHECK(mismatches == 0);
        } else if (e.name == "half.exact") {
            for (size_t i = 0; i < n; ++i) CHECK(got[i] == e.data[i]);
        } else {
            for (size_t i = 0; i < n; ++i)
                CHECK(std::fabs(got[i] - e.data[i]) <= std::fabs(e.data[i]) * (1.0f / 1024.0f));
        }
    }

    // Row-major, top row first: pixel (x=3, y=1) is index 1*w+3.
    for (const auto& e : ch)
        if (e.name == "lum_mean") CHECK(img.channels.at("lum_mean")[1 * w + 3] == e.data[1 * w + 3]);

    // Header: single-part scanline, ZIP compression, data window [0,w-1]x[0,h-1].
    Imf::InputFile f(path.c_str());
    CHECK(f.header().compression() == Imf::ZIP_COMPRESSION);
    CHECK(f.header().dataWindow().min.x == 0);
    CHECK(f.header().dataWindow().max.x == w - 1);
    CHECK(f.header().dataWindow().max.y == h - 1);
    CHECK(f.header().channels().findChannel("bucket.direct") != nullptr);
    CHECK(f.header().channels().findChannel("half.exact")->type == Imf::HALF);
    CHECK(f.header().channels().findChannel("R")->type == Imf::FLOAT);
}

TEST_CASE("io: EXR overwrite is atomic and replaces the old content") {
    TempDir tmp("exr_over");
    const std::string path = (tmp.path / "a.exr").string();
    vkmech::write_exr_layers(path, 2, 2, {{"Y", {1, 2, 3, 4}, false}});
    vkmech::write_exr_layers(path, 3, 1, {{"Z", {5, 6, 7}, false}, {"A", {8, 9, 10}, false}});
    auto img = vkmech::read_exr_channels(path);
    CHECK(img.width == 3);
    CHECK(img.height == 1);
    CHECK(img.order == std::vector<std::string>{"Z", "A"});
    CHECK(img.channels.count("Y") == 0);
    CHECK(img.channels.at("A") == std::vector<float>{8, 9, 10});
    CHECK(count_temp_files(tmp.path) == 0);
}

TEST_CASE("io: EXR invalid arguments throw and leave the old file untouched") {
    TempDir tmp("exr_bad");
    const std::string path = (tmp.path / "a.exr").string();
    vkmech::write_exr_layers(path, 2, 1, {{"Y", {1, 2}, false}});
    const std::string before = slurp(path);
    CHECK_THROWS_AS(vkmech::write_exr_layers(path, 2, 1, {{"Y", {1, 2, 3}, false}}), std::runtime_error);
    CHECK_THROWS_AS(vkmech::write_exr_layers(path, 2, 1, {{"Y", {1, 2}, false}, {"Y", {1, 2}, false}}),
                    std::runtime_error);
    CHECK_THROWS_AS(vkmech::write_exr_layers(path, 2, 1, {{"", {1, 2}, false}}), std::runtime_error);
    CHECK_THROWS_AS(vkmech::write_exr_layers(path, 0, 1, {}), std::runtime_error);
    CHECK_THROWS_AS(vkmech::write_exr_layers(path, 2, 1, {}), std::runtime_error);
    CHECK(slurp(path) == before);
    CHECK(count_temp_files(tmp.path) == 0);
    try {
        vkmech::write_exr_layers(path, 2, 1, {{"Y", {1}, false}});
    } catch (const std::runtime_error& e) {
        CHECK(std::string(e.what()).find(path) != std::string::npos);
    }
}

TEST_CASE("io: failed writes throw with the path and leave no temporary file") {
    SUBCASE("parent directory cannot be created") {
        const std::string path = kUncreatable + ".exr";
        try {
            vkmech::write_exr_layers(path, 1, 1, {{"Y", {1.0f}, false}});
            FAIL("expected an exception");
        } catch (const std::runtime_error& e) {
            CHECK(std::string(e.what()).find(path) != std::string::npos);
        }
        CHECK_FALSE(fs::exists(vkmech::atomic_temp_path(path)));
        CHECK_THROWS_AS(vkmech::write_png_rgb8(kUncreatable + ".png", 1, 1, {1, 2, 3}), std::runtime_error);
        CHECK_THROWS_AS(vkmech::write_file_atomic(kUncreatable + ".json", "{}"), std::runtime_error);
    }
    SUBCASE("rename fails after the temporary was written (target is a directory)") {
        TempDir tmp("fail");
        const fs::path target = tmp.path / "target";
        fs::create_directories(target / "keep");
        try {
            vkmech::write_exr_layers(target.string(), 2, 2, {{"Y", {1, 2, 3, 4}, false}});
            FAIL("expected an exception");
        } catch (const std::runtime_error& e) {
            CHECK(std::string(e.what()).find(target.string()) != std::string::npos);
        }
        CHECK_THROWS_AS(vkmech::write_png_rgb8(target.string(), 1, 1, {1, 2, 3}), std::runtime_error);
        CHECK_THROWS_AS(vkmech::write_file_atomic(target.string(), "x"), std::runtime_error);
        CHECK(count_temp_files(tmp.path) == 0);
        CHECK(fs::is_directory(target / "keep"));
    }
    SUBCASE("reading a missing or corrupt EXR throws") {
        TempDir tmp("read");
        CHECK_THROWS_AS(vkmech::read_exr_channels((tmp.path / "missing.exr").string()), std::runtime_error);
        vkmech::write_file_atomic((tmp.path / "junk.exr").string(), "not an exr file");
        CHECK_THROWS_AS(vkmech::read_exr_channels((tmp.path / "junk.exr").string()), std::runtime_error);
    }
}

TEST_CASE("io: write_file_atomic creates parents and leaves no temporary") {
    TempDir tmp("atomic");
    const fs::path p = tmp.path / "a" / "b" / "summary.json";
    vkmech::write_file_atomic(p.string(), "{\"x\": 1}\n");
    CHECK(slurp(p) == "{\"x\": 1}\n");
    vkmech::write_file_atomic(p.string(), "");
    CHECK(fs::file_size(p) == 0);
    std::string big(3 << 20, 'z');
    vkmech::write_file_atomic(p.string(), big);
    CHECK(slurp(p) == big);
    CHECK(count_temp_files(tmp.path) == 0);
}

TEST_CASE("io: PNG written is readable by stb_image with the same pixels") {
    TempDir tmp("png");
    const int w = 5, h = 3;
    std::vector<uint8_t> rgb(3 * w * h);
    for (size_t i = 0; i < rgb.size(); ++i) rgb[i] = static_cast<uint8_t>((i * 37 + 11) & 0xff);
    const fs::path p = tmp.path / "sub" / "img.png";
    vkmech::write_png_rgb8(p.string(), w, h, rgb);
    CHECK(count_temp_files(tmp.path) == 0);
    int x = 0, y = 0, comp = 0;
    unsigned char* data = stbi_load(p.string().c_str(), &x, &y, &comp, 3);
    REQUIRE(data != nullptr);
    CHECK(x == w);
    CHECK(y == h);
    CHECK(comp == 3);
    CHECK(std::vector<uint8_t>(data, data + rgb.size()) == rgb);
    stbi_image_free(data);

    CHECK_THROWS_AS(vkmech::write_png_rgb8(p.string(), w, h, std::vector<uint8_t>(7)), std::runtime_error);
    CHECK_THROWS_AS(vkmech::write_png_rgb8(p.string(), 0, h, {}), std::runtime_error);
}

TEST_CASE("io: tonemap_srgb and grey_to_rgb8 known values") {
    const float nan = std::numeric_limits<float>::quiet_NaN();
    const float inf = std::numeric_limits<float>::infinity();
    auto t = vkmech::tonemap_srgb({0.0f, 1.0f, 0.5f, nan, 0.5f, 0.5f, 2.0f, -1.0f, 0.0031308f, 0.25f, 0.25f, inf});
    REQUIRE(t.size() == 12);
    CHECK(t[0] == 0);
    CHECK(t[1] == 255);
    CHECK(t[2] == 188);
    CHECK(t[3] == 255);  // NaN pixel -> magenta
    CHECK(t[4] == 0);
    CHECK(t[5] == 255);
    CHECK(t[6] == 255);  // clamped high
    CHECK(t[7] == 0);    // clamped low
    CHECK(t[8] == 10);   // 12.92 * 0.0031308 * 255 = 10.3
    CHECK(t[9] == 255);  // inf pixel -> magenta
    CHECK(t[10] == 0);
    CHECK(t[11] == 255);
    auto e = vkmech::tonemap_srgb({0.25f, 0.25f, 0.25f}, 2.0f);
    CHECK(e == std::vector<uint8_t>{188, 188, 188});
    CHECK_THROWS_AS(vkmech::tonemap_srgb({1.0f, 2.0f}), vkmech::InternalError);  // every caller passes RGB

    auto g = vkmech::grey_to_rgb8({0.0f, 1.0f, 0.5f, -1.0f, 2.0f, nan}, 0.0f, 1.0f);
    CHECK(g == std::vector<uint8_t>{0, 0, 0, 255, 255, 255, 128, 128, 128, 0, 0, 0, 255, 255, 255, 255, 0, 255});
    auto g2 = vkmech::grey_to_rgb8({2.0f, 3.0f}, 1.0f, 5.0f);
    CHECK(g2 == std::vector<uint8_t>{64, 64, 64, 128, 128, 128});
}

// docs/reliability.md: the reader allocates what the header claims. A 2x2 file whose
// dataWindow is patched to claim 100000 x 100000 pixels (or a window whose
// width overflows int) is refused with a message naming the file, never a
// 40 GB allocation. (OpenEXR 3.1 itself already refuses both, from the
// missing line offsets; read_exr_channels checks the claim as well, in 64
// bits, in case a file gets past that.)
TEST_CASE("exr: a header claiming a huge data window is refused with the file named") {
    TempDir dir("exr_huge");
    const std::string path = (dir.path / "huge.exr").string();
    vkmech::write_exr_layers(path, 2, 2, {{"Y", {1, 2, 3, 4}, false}});
    std::string bytes;
    {
        std::ifstream in(path, std::ios::binary);
        std::stringstream ss;
        ss << in.rdbuf();
        bytes = ss.str();
    }
    const std::string tag("dataWindow\0box2i\0", 17);
    const size_t at = bytes.find(tag);
    REQUIRE(at != std::string::npos);
    const size_t box = at + tag.size() + 4;  // after the attribute's int32 size
    for (const auto& [min_xy, max_xy] :
         {std::pair<int32_t, int32_t>{0, 99999},
          std::pair<int32_t, int32_t>{std::numeric_limits<int32_t>::min(), std::numeric_limits<int32_t>::max()}}) {
        std::string patched = bytes;
        const int32_t win[4] = {min_xy, min_xy, max_xy, max_xy};
        std::memcpy(&patched[box], win, sizeof win);
        {
            std::ofstream out(path, std::ios::binary | std::ios::trunc);
            out << patched;
        }
        std::string message;
        try {
            vkmech::read_exr_channels(path);
        } catch (const std::exception& e) {
            message = e.what();
        }
        INFO(message);
        CHECK(message.find("huge.exr") != std::string::npos);
    }
}
