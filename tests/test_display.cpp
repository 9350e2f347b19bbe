// --display-server: a listener of the test's own on the loopback decodes tev's
// IPC stream (its documented wire format, read here independently of the
// client) and must end with the EXR's channels and pixels; a viewer that is
// absent or goes away must not fail the render.
#include "cli_run.hpp"
#include "gpu_fixture.hpp"
#include "temp_dir.hpp"

#include "io/display_client.hpp"
#include "io/exr.hpp"

#include <doctest/doctest.h>

#include <netinet/in.h>
#include <sys/socket.h>
#include <sys/time.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

using namespace vkmech;

namespace {

// A listening socket on 127.0.0.1 at a port the system picks.
struct Listener {
    int fd = -1;
    int port = 0;
    Listener() {
        fd = ::socket(AF_INET, SOCK_STREAM, 0);
        sockaddr_in a{};
        a.sin_family = AF_INET;
        a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
        a.sin_port = 0;
        REQUIRE(::bind(fd, reinterpret_cast<sockaddr*>(&a), sizeof a) == 0);
        REQUIRE(::listen(fd, 1) == 0);
        timeval tv{60, 0};  // accept and recv give up after a minute: a broken client fails, never hangs
        ::setsockopt(fd, SOL_SOCKET, SO_RCVTIMEO, &tv, sizeof tv);
        socklen_t len = sizeof a;
        ::getsockname(fd, reinterpret_cast<sockaddr*>(&a), &len);
        port = ntohs(a.sin_port);
    }
    ~Listener() {
        if (fd >= 0) ::close(fd);
    }
    std::string address() const { return "127.0.0.1:" + std::to_string(port); }
};

// An image as a viewer holds it after the stream: created, then each update applied.
struct Image {
    std::string name;
    int width = 0, height = 0;
    std::vector<std::string> channels;
    std::map<std::string, std::vector<float>> planes;
};

// The stream decoded: the first image created (the render's own), and every image by name.
struct Decoded : Image {
    int packets = 0, creates = 0, updates = 0;
    std::string error;
    std::map<std::string, Image> images;
};

struct Reader {
    const std::vector<uint8_t>& b;
    size_t at;
    uint32_t u32() {
        uint32_t v = 0;
        for (int k = 0; k < 4; ++k) v |= static_cast<uint32_t>(b.at(at++)) << (8 * k);
        return v;
    }
    uint64_t u64() {
        uint64_t v = 0;
        for (int k = 0; k < 8; ++k) v |= static_cast<uint64_t>(b.at(at++)) << (8 * k);
        return v;
    }
    std::string str() {
        std::string s;
        while (b.at(at) != 0) s += static_cast<char>(b[at++]);
        ++at;
        return s;
    }
    float f32() {
        const uint32_t u = u32();
        float f;
        std::memcpy(&f, &u, 4);
        return f;
    }
};

// Decodes the packets of `bytes` (as many as are whole).
Decoded decode(const std::vector<uint8_t>& bytes) {
    Decoded d;
    std::string first;
    size_t at = 0;
    while (at + 4 <= bytes.size()) {
        Reader r{bytes, at};
        const uint32_t length = r.u32();
        if (length < 5 || at + length > bytes.size()) break;
        const uint8_t type = bytes[r.at++];
        ++d.packets;
        r.at++;  // grab focus
        if (type == 4) {
            ++d.creates;
            Image img;
            img.name = r.str();
            img.width = static_cast<int>(r.u32());
            img.height = static_cast<int>(r.u32());
            const uint32_t n = r.u32();
            for (uint32_t c = 0; c < n; ++c) {
                img.channels.push_back(r.str());
                img.planes[img.channels.back()].assign(static_cast<size_t>(img.width) * img.height, 0.0f);
            }
            if (first.empty()) first = img.name;
            d.images[img.name] = img;
        } else if (type == 6) {
            ++d.updates;
            const std::string name = r.str();
            if (d.images.count(name) == 0) {
                d.error = "an update of an image never created: " + name;
                break;
            }
            Image& img = d.images[name];
            const uint32_t n = r.u32();
            std::vector<std::string> names;
            for (uint32_t c = 0; c < n; ++c) names.push_back(r.str());
            const int x = static_cast<int>(r.u32()), y = static_cast<int>(r.u32());
            const int w = static_cast<int>(r.u32()), h = static_cast<int>(r.u32());
            std::vector<uint64_t> offset(n), stride(n);
            for (auto& o : offset) o = r.u64();
            for (auto& s : stride) s = r.u64();
            const size_t data = r.at;
            for (uint32_t c = 0; c < n; ++c)
                for (int j = 0; j < h; ++j)
                    for (int i = 0; i < w; ++i) {
                        Reader p{bytes, data + 4 * (offset[c] + static_cast<uint64_t>(j * w + i) * stride[c])};
                        img.planes[names[c]].at(static_cast<size_t>(y + j) * img.width + x + i) = p.f32();
                    }
        } else {
            d.error = "packet type " + std::to_string(type);
        }
        at += length;
    }
    if (!first.empty()) static_cast<Image&>(d) = d.images.at(first);
    return d;
}

// Accepts one connection and reads it to the end (or, with `stop_after` > 0,
// closes it after that many bytes: a viewer that goes away).
std::vector<uint8_t> serve(Listener& l, size_t stop_after = 0) {
    std::vector<uint8_t> bytes;
    const int c = ::accept(l.fd, nullptr, nullptr);
    if (c < 0) return bytes;
    timeval tv{60, 0};
    ::setsockopt(c, SOL_SOCKET, SO_RCVTIMEO, &tv, sizeof tv);
    uint8_t buf[1 << 16];
    for (;;) {
        const ssize_t n = ::recv(c, buf, sizeof buf, 0);
        if (n <= 0) break;
        bytes.insert(bytes.end(), buf, buf + n);
        if (stop_after > 0 && bytes.size() >= stop_after) break;
    }
    ::close(c);
    return bytes;
}

// Runs `vkmech <args> --display-server` at a loopback viewer of the test's own and decodes what it got.
struct Streamed {
    testing::CliRun run;
    Decoded d;
};
Streamed render_streamed(const std::string& args) {
    Listener l;
    std::vector<uint8_t> bytes;
    std::thread viewer([&] { bytes = serve(l); });
    testing::CliRun run = testing::run_cli(args + " --display-server " + l.address());
    viewer.join();
    return {run, decode(bytes)};
}

}  // namespace

TEST_CASE("display: tev's packets - the create and update layouts decode as documented") {
    const auto create = tev_create_image("img", 3, 2, {"R", "lum.direct"});
    const std::vector<float> r = {0, 1, 2, 3, 4, 5}, l = {10, 11, 12, 13, 14, 15};
    const auto update = tev_update_image("img", {"R", "lum.direct"}, {&r, &l}, 3, 1, 0, 2, 2);
    std::vector<uint8_t> stream = create;
    stream.insert(stream.end(), update.begin(), update.end());
    CHECK(create[0] == create.size());  // the length counts its own 4 bytes
    const Decoded d = decode(stream);
    CHECK(d.error.empty());
    CHECK(d.creates == 1);
    CHECK(d.updates == 1);
    CHECK(d.name == "img");
    CHECK(d.width == 3);
    CHECK(d.height == 2);
    CHECK(d.channels == std::vector<std::string>{"R", "lum.direct"});
    // The tile x in [1, 3), y in [0, 2); column 0 stays as created (0).
    CHECK(d.planes.at("R") == std::vector<float>{0, 1, 2, 0, 4, 5});
    CHECK(d.planes.at("lum.direct") == std::vector<float>{0, 11, 12, 0, 14, 15});
}

TEST_SUITE("gpu") {
    TEST_CASE("display: a render streamed to a loopback viewer ends with the EXR's channels and pixels") {
        VKMECH_REQUIRE_GPU(ctx);
        testing::TempDir dir("display");
        const Streamed st =
            render_streamed("render --scene cubes_dof --res 40 --spp 8 --batch 2 --out " + dir.path.string());
        const testing::CliRun& run = st.run;
        const Decoded& d = st.d;
        CAPTURE(run.output);
        REQUIRE(run.code == 0);
        CHECK(run.output.find("display server") == std::string::npos);  // no warning
        CHECK(d.error.empty());
        CHECK(d.creates == 1);
        CHECK(d.updates >= 1);
        CHECK(d.name.rfind("cubes_dof (", 0) == 0);
        const ExrImage exr = read_exr_channels(dir.file("cubes_dof.exr"));
        CHECK(d.width == exr.width);
        CHECK(d.height == exr.height);
        REQUIRE(d.channels.size() == exr.channels.size());
        for (const auto& name : d.channels) {
            CAPTURE(name);
            REQUIRE(exr.channels.count(name) == 1);
            const auto& a = d.planes.at(name);
            const auto& b = exr.channels.at(name);
            REQUIRE(a.size() == b.size());
            size_t differ = 0;
            for (size_t i = 0; i < a.size(); ++i) {
                // A channel stored as half in the EXR is the streamed float rounded.
                const float tol = exr.half_channels.count(name) ? 1e-3f * std::abs(a[i]) + 1e-6f : 0.0f;
                differ += !(std::abs(a[i] - b[i]) <= tol);
            }
            CHECK(differ == 0);
        }
    }

    TEST_CASE("display: an adaptive render sends its pilot and allocation map, then streams the final image") {
        VKMECH_REQUIRE_GPU(ctx);
        testing::TempDir dir("display_adaptive");
        const Streamed st = render_streamed(
            "render --scene ring_caustic --res 24 --adaptive guarded --pilot 16 --budget 8 --out " + dir.path.string());
        const Decoded& d = st.d;
        CAPTURE(st.run.output);
        REQUIRE(st.run.code == 0);
        CHECK(d.error.empty());
        REQUIRE(d.images.size() == 3);
        const std::string pid = d.name.substr(d.name.rfind(" ("));
        CHECK(d.name == "ring_caustic pilot" + pid);
        REQUIRE(d.images.count("ring_caustic allocation" + pid) == 1);
        REQUIRE(d.images.count("ring_caustic" + pid) == 1);
        // The allocation map is the final render's n(p): its spp channel.
        const ExrImage exr = read_exr_channels(dir.file("ring_caustic.exr"));
        const Image& alloc = d.images.at("ring_caustic allocation" + pid);
        CHECK(alloc.channels == std::vector<std::string>{"n", "untrusted"});
        CHECK(alloc.planes.at("n") == exr.channels.at("spp"));
        // The final image ends as the EXR (every channel the EXR holds, same pixels in R).
        const Image& final_image = d.images.at("ring_caustic" + pid);
        CHECK(final_image.channels.size() == exr.channels.size());
        CHECK(final_image.planes.at("R") == exr.channels.at("R"));
        // The pilot has the pilot's samples everywhere: 16.
        const auto& pilot_spp = d.planes.at("spp");
        CHECK(std::all_of(pilot_spp.begin(), pilot_spp.end(), [](float v) { return v == 16.0f; }));
    }

    TEST_CASE("display: a noise-threshold render streams every channel of its EXR, err included") {
        VKMECH_REQUIRE_GPU(ctx);
        testing::TempDir dir("display_threshold");
        const Streamed st = render_streamed(
            "render --scene ring_caustic --res 24 --noise-threshold 0.2 --min-spp 8 --max-spp 64 --out " +
            dir.path.string());
        const Decoded& d = st.d;
        CAPTURE(st.run.output);
        REQUIRE(st.run.code == 0);
        CHECK(d.error.empty());
        CHECK(d.images.size() == 1);
        const ExrImage exr = read_exr_channels(dir.file("ring_caustic.exr"));
        CHECK(d.channels.size() == exr.channels.size());
        for (const char* c : {"R", "spp", "err"}) {
            CAPTURE(c);
            REQUIRE(d.planes.count(c) == 1);
            CHECK(d.planes.at(c) == exr.channels.at(c));
        }
    }

    TEST_CASE("display: a study streams its renders, one image per scene variant, and its tables are as without") {
        VKMECH_REQUIRE_GPU(ctx);
        testing::TempDir dir("display_study");
        const std::string study = "study stability --scenes cubes_dof --res 16 --spp-levels 4 8 --seeds 4 --no-plots ";
        const Streamed st = render_streamed(study + "--out " + dir.file("a"));
        CAPTURE(st.run.output);
        REQUIRE(st.run.code == 0);
        const Decoded& d = st.d;
        CHECK(d.error.empty());
        REQUIRE(d.images.size() == 1);
        CHECK(d.name.rfind("study cubes_dof (", 0) == 0);
        CHECK(d.updates >= 8);  // at least once per render: eight renders
        CHECK(d.planes.count("dominant") == 1);
        // The last render streamed is the last the study rendered: 8 samples per pixel.
        const auto& spp = d.planes.at("spp");
        CHECK(std::all_of(spp.begin(), spp.end(), [](float v) { return v == 8.0f; }));
        const testing::CliRun plain = testing::run_cli(study + "--out " + dir.file("b"));
        REQUIRE(plain.code == 0);
        std::ifstream a(dir.file("a/tables/kappa.csv")), b(dir.file("b/tables/kappa.csv"));
        std::stringstream ta, tb;
        ta << a.rdbuf();
        tb << b.rdbuf();
        CHECK_FALSE(ta.str().empty());
        CHECK(ta.str() == tb.str());
    }

    TEST_CASE("display: a render whose viewer is absent or goes away still completes") {
        VKMECH_REQUIRE_GPU(ctx);
        testing::TempDir dir("display_gone");
        int absent_port = 0;
        {
            Listener gone;  // bound, then closed: nobody listens at its port
            absent_port = gone.port;
        }
        const testing::CliRun absent =
            testing::run_cli("render --scene cubes_dof --res 24 --spp 4 --out " + dir.file("a") +
                             " --display-server 127.0.0.1:" + std::to_string(absent_port));
        CAPTURE(absent.output);
        CHECK(absent.code == 0);
        CHECK(absent.output.find("display server 127.0.0.1:") != std::string::npos);
        CHECK(std::filesystem::exists(dir.file("a/cubes_dof.exr")));

        Listener l;
        std::thread viewer([&] { serve(l, 64); });  // reads the first bytes, then goes away
        const testing::CliRun vanishes = testing::run_cli("render --scene cubes_dof --res 64 --spp 8 --batch 1 --out " +
                                                          dir.file("b") + " --display-server " + l.address());
        viewer.join();
        CAPTURE(vanishes.output);
        CHECK(vanishes.code == 0);
        CHECK(std::filesystem::exists(dir.file("b/cubes_dof.exr")));

        const testing::CliRun malformed = testing::run_cli("render --scene cubes_dof --res 16 --spp 1 --out " +
                                                           dir.file("c") + " --display-server nonsense");
        CHECK(malformed.code == 0);
        CHECK(malformed.output.find("'nonsense' is not host:port") != std::string::npos);
    }
}
