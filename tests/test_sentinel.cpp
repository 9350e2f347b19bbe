// Sentinel pre-registration (docs/descriptor.md §9): SHA-256,
// the record's seal, the prediction rules and that registering renders only
// the pilot.
#include "adaptive/adaptive.hpp"
#include "cli_run.hpp"
#include "experiments/sentinel.hpp"
#include "experiments/sentinel_eval.hpp"
#include "gpu_fixture.hpp"
#include "io/json_value.hpp"
#include "io/sha256.hpp"
#include "render/session.hpp"
#include "scene/scene.hpp"
#include "study/sentinel_register.hpp"
#include "temp_dir.hpp"

#include <doctest/doctest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

using namespace vkmech;

using testing::read_text;

namespace {

void write_text(const std::string& path, const std::string& s) {
    std::ofstream out(path, std::ios::binary);
    out << s;
}

// A pilot of w x h pixels, each seen with `spp` finite samples (default 16) of a variance, all in bucket `bucket`.
Frame synthetic_pilot(int w, int h, uint32_t bucket, int spp = 16) {
    Frame f;
    f.width = w;
    f.height = h;
    f.pixels.resize(static_cast<size_t>(w) * h);
    for (size_t p = 0; p < f.pixels.size(); ++p) {
        PixelStats& s = f.pixels[p];
        s.count = spp;
        s.lum_mean = 0.5 + 0.01 * static_cast<double>(p % 7);
        s.lum_m2 = 0.1 + 0.02 * static_cast<double>(p % 5);
        s.rgb_sum = {s.lum_mean * spp, s.lum_mean * spp, s.lum_mean * spp};
        s.bucket_sum[bucket] = s.lum_mean * spp;
    }
    f.samples = static_cast<uint64_t>(spp) * f.pixels.size();
    return f;
}

const sentinel::Prediction* find(const std::vector<sentinel::Prediction>& ps, const std::string& name) {
    for (const auto& p : ps)
        if (p.name == name) return &p;
    return nullptr;
}

sentinel::Record small_record() {
    const Frame f = synthetic_pilot(4, 4, 0);
    const Pilot pilot = make_pilot(f, {});
    sentinel::Record r;
    r.scene_name = "synthetic";
    r.scene_path = "/nowhere/synthetic.xml";
    r.scene_sha256 = sha256_hex("scene");
    r.width = r.height = 4;
    r.pilot_spp = 8;
    r.pilot_seed = 100000;
    r.renders.push_back({100000, 8});
    r.estimator = "nee";
    r.registered_utc = "2025-01-01T00:00:00Z";
    r.device = "test";
    r.diagnosis = alloc::diagnose_pilot(pilot);
    r.predictions = sentinel::predict(pilot.frame, r.diagnosis, nullptr, nullptr);
    return r;
}

}  // namespace

TEST_CASE("sentinel: a record read back from its JSON keeps what evaluate needs") {
    sentinel::Record r = small_record();
    r.params = {{"alpha", "0.03"}, {"lights", "4"}};
    r.scene_files.push_back({"/nowhere/tex.png", sha256_hex("tex")});
    r.protocol = {512, 7, 16, 4};
    r.curve_path = "/nowhere/curve.json";
    r.curve_sha256 = sha256_hex("curve");
    r.curve_pilot_spp = 64;
    r.curve_reference_spp = 2048;
    const auto doc = parse_json(sentinel::seal(sentinel::record_json(r)));
    REQUIRE(doc);
    const sentinel::Record b = sentinel::parse_record(*doc);
    CHECK(b.scene_path == r.scene_path);
    CHECK(b.scene_sha256 == r.scene_sha256);
    CHECK(b.params == r.params);
    REQUIRE(b.scene_files.size() == 1);
    CHECK(b.scene_files[0].sha256 == r.scene_files[0].sha256);
    CHECK(b.protocol.reference_spp == 512);
    CHECK(b.protocol.draws == 7);
    CHECK(b.protocol.extra_spp == 16);
    CHECK(b.protocol.floor == 4);
    CHECK(b.curve_reference_spp == 2048);
    CHECK(b.pilot_spp == r.pilot_spp);
    CHECK(b.pilot_seed == r.pilot_seed);
    CHECK(b.diagnosis.labelled == r.diagnosis.labelled);
    CHECK(b.diagnosis.untrusted == r.diagnosis.untrusted);
    REQUIRE(b.predictions.size() == r.predictions.size());
    for (size_t i = 0; i < b.predictions.size(); ++i) {
        CHECK(b.predictions[i].name == r.predictions[i].name);
        CHECK(b.predictions[i].outcome == r.predictions[i].outcome);
        CHECK(b.predictions[i].pass_if == r.predictions[i].pass_if);
        CHECK(!b.predictions[i].pass_if.empty());
        if (r.predictions[i].outcome.empty()) {
            CHECK(b.predictions[i].value == doctest::Approx(r.predictions[i].value).epsilon(1e-8));
            CHECK(b.predictions[i].tolerance == doctest::Approx(r.predictions[i].tolerance));
        }
    }
}

namespace {

// A 4x4 film, all diffuse_indirect: pixels 0..7 ("A") constant 1, pixels 8..15
// ("B") alternate 1 + a, 1 - a sample by sample in the pool. The reference is
// exactly 1. The pilot is misleading: it sees variance in A and none in B, so
// observed-var gives B its floor of one sample (error a^2) where uniform gives
// it 33 (error (a/33)^2): observed-var fails against uniform on every draw.
struct MisleadingScene {
    static constexpr int W = 4, H = 4;
    static constexpr size_t P = 16;
    static constexpr double a = 0.5;
    Frame reference;
    SamplePool pool;
    std::vector<Pilot> pilots;
    MisleadingScene(int draws) {
        reference.width = W;
        reference.height = H;
        reference.pixels.resize(P);
        for (auto& px : reference.pixels) {
            px.count = 1000;
            px.rgb_sum = {1000, 1000, 1000};
            px.lum_mean = 1;
            px.bucket_sum[2] = 1000;
        }
        reference.samples = 1000 * P;
        pool.frames = downstream_seeds::kPoolSize;
        pool.pixels = P;
        pool.samples.assign(pool.frames * P * 4, 0.0f);
        for (uint32_t f = 0; f < pool.frames; ++f)
            for (size_t p = 0; p < P; ++p) {
                const float v = p < 8 ? 1.0f : (f % 2 == 0 ? 1.0f + float(a) : 1.0f - float(a));
                float* x = &pool.samples[(f * P + p) * 4];
                x[0] = x[1] = x[2] = v;
                x[3] = 1.0f;
            }
        pool.oracle_var.assign(P, 0.0);
        for (size_t p = 8; p < P; ++p) pool.oracle_var[p] = a * a;
        for (int k = 0; k < draws; ++k) {
            Frame f = reference;
            for (size_t p = 0; p < P; ++p) {
                f.pixels[p].count = 16;
                f.pixels[p].rgb_sum = {16, 16, 16};
                f.pixels[p].bucket_sum[2] = 16;
                f.pixels[p].lum_m2 = p < 8 ? 15.0 * (1.0 + k) : 0.0;
            }
            f.samples = 16 * P;
            pilots.push_back(make_pilot(f, {}));
        }
    }
};

sentinel::Prediction numeric(const std::string& name, double value, double tol) {
    sentinel::Prediction p;
    p.name = name;
    p.value = value;
    p.tolerance = tol;
    return p;
}
sentinel::Prediction categorical(const std::string& name, const std::string& outcome) {
    sentinel::Prediction p;
    p.name = name;
    p.outcome = outcome;
    return p;
}
std::string verdict(const sentinel::Evaluation& e, const std::string& name) {
    for (const auto& o : e.outcomes)
        if (o.name == name) return o.verdict;
    return "missing";
}

}  // namespace

TEST_CASE("sentinel: evaluate decides every prediction by its registered rule") {
    MisleadingScene s(3);
    sentinel::Record r;
    r.scene_name = "misleading";
    r.width = MisleadingScene::W;
    r.height = MisleadingScene::H;
    r.pilot_spp = 16;
    r.protocol = {1000, 3, 32, 1};
    r.diagnosis = alloc::diagnose_pilot(s.pilots[0]);
    r.predictions = {numeric("coverage.diffuse_indirect.pixel_share", 0.97, 0.05),
                     numeric("coverage.direct.pixel_share", 0.10, 0.05),
                     numeric("coverage.diffuse_indirect.energy_share", 1.0, 0.0),
                     numeric("reliability.margin", 0.95, 0.09),
                     numeric("reliability.purity", 0.80, 0.09),
                     categorical("allocation.observed-var_vs_uniform", "fails"),
                     categorical("allocation.bucket-floor_vs_uniform", "helps"),
                     categorical("allocation.bucket-floor_vs_observed-var", "no-op"),
                     categorical("allocation.guarded_vs_bucket-floor", "no-op"),
                     categorical("allocation.nonsense_vs_uniform", "helps"),
                     categorical("structure.rho_CG_sign", "positive"),
                     categorical("something.new", "positive")};
    sentinel::EvalInputs in;
    in.reference = &s.reference;
    in.pool = &s.pool;
    in.pilots = s.pilots;
    const sentinel::Evaluation e = sentinel::evaluate(r, in);
    CHECK(e.pilot_reproduced);
    CHECK(verdict(e, "coverage.diffuse_indirect.pixel_share") == "PASS");   // measured 1.0, |0.03| <= 0.05
    CHECK(verdict(e, "coverage.direct.pixel_share") == "FAIL");             // measured 0.0, |0.10| > 0.05
    CHECK(verdict(e, "coverage.diffuse_indirect.energy_share") == "PASS");  // exactly 1.0 within a band of 0
    CHECK(verdict(e, "reliability.margin") == "PASS");                      // agreement 1.0
    CHECK(verdict(e, "reliability.purity") == "FAIL");
    CHECK(verdict(e, "allocation.observed-var_vs_uniform") == "PASS");  // the floor of 1 in B: a^2 against (a/33)^2
    CHECK(verdict(e, "allocation.bucket-floor_vs_uniform") == "FAIL");
    CHECK(verdict(e, "allocation.bucket-floor_vs_observed-var") == "PASS");  // no heavy label: identical plans
    // B is lit with no pilot variance: untrusted, so guarded moves samples there and is not a no-op.
    CHECK(r.diagnosis.untrusted == 8);
    CHECK(verdict(e, "allocation.guarded_vs_bucket-floor") == "FAIL");
    CHECK(verdict(e, "allocation.nonsense_vs_uniform") == "INDETERMINATE");
    CHECK(verdict(e, "structure.rho_CG_sign") == "INDETERMINATE");  // no caustic or glossy energy: degenerate
    CHECK(verdict(e, "something.new") == "INDETERMINATE");
    CHECK(e.pass == 5);
    CHECK(e.fail == 4);
    CHECK(e.indeterminate == 3);
    // The uniform image: A exact, B the mean of 33 alternating samples (one extra 1 + a): error (a/33)^2 on half the
    // pixels.
    const double uniform_mse = 0.5 * (0.5 / 33) * (0.5 / 33);
    REQUIRE(e.strategies.front().name == "uniform");
    CHECK(e.strategies.front().mse[0] == doctest::Approx(uniform_mse).epsilon(1e-6));
    CHECK(e.peak == doctest::Approx(1.0));

    // A registered diagnosis that the pilot does not reproduce is reported, not hidden.
    r.diagnosis.labelled = 3;
    CHECK_FALSE(sentinel::evaluate(r, in).pilot_reproduced);
    // The inputs must match the protocol.
    r.protocol.draws = 2;
    CHECK_THROWS_AS(sentinel::evaluate(r, in), std::invalid_argument);
}

TEST_CASE("sentinel: the loader lists the mesh and include files a record must digest") {
    testing::TempDir dir("sentinel_files");
    write_text(dir.file("tri.obj"), "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
    write_text(dir.file("part.xml"),
               "<scene version=\"3.0.0\"><shape type=\"obj\"><string name=\"filename\" "
               "value=\"tri.obj\"/></shape></scene>\n");
    write_text(dir.file("main.xml"),
               "<scene version=\"3.0.0\"><sensor type=\"perspective\"><float name=\"fov\" value=\"40\"/>"
               "<transform name=\"to_world\"><lookat origin=\"0, 0, 5\" target=\"0, 0, 0\" up=\"0, 1, 0\"/></transform>"
               "</sensor><include filename=\"part.xml\"/></scene>\n");
    const Scene scene = load_scene(dir.file("main.xml"));
    auto has = [&](const std::string& name) {
        for (const auto& f : scene.files)
            if (std::filesystem::path(f).filename() == name) return true;
        return false;
    };
    CHECK(has("part.xml"));
    CHECK(has("tri.obj"));
}

TEST_CASE("sentinel: sha256 matches the FIPS 180 test vectors") {
    CHECK(sha256_hex("") == "e3b0c44298fc1c149afbf4c8996fb92427ae41e4649b934ca495991b7852b855");
    CHECK(sha256_hex("abc") == "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad");
    CHECK(sha256_hex("abcdbcdecdefdefgefghfghighijhijkijkljklmklmnlmnomnopnopq") ==
          "248d6a61d20638b8e5c026930c3e6039a33ce45964ff2167f6ecedd419db06c1");
    CHECK(sha256_hex(std::string(1000000, 'a')) == "cdc76e5c9914fb9281a1c7e284d73e67f1809a48a497200e046d39ccc7112cd0");
    // Fed in uneven pieces, the same digest.
    const std::string m = "abcdbcdecdefdefgefghfghighijhijkijkljklmklmnlmnomnopnopq";
    Sha256 h;
    for (size_t i = 0; i < m.size(); i += 5) h.update(m.substr(i, 5));
    CHECK(h.hex() == "248d6a61d20638b8e5c026930c3e6039a33ce45964ff2167f6ecedd419db06c1");
}

TEST_CASE("sentinel: an untouched record is accepted and one edited after registration is refused") {
    const std::string sealed = sentinel::seal(sentinel::record_json(small_record()));
    REQUIRE(parse_json(sealed));
    const auto ok = sentinel::verify_record(sealed, "r.json");
    INFO(ok.message);
    CHECK(ok.kind == sentinel::Verification::Intact);
    CHECK(ok.message.find("intact") != std::string::npos);

    // One predicted outcome changed.
    std::string edited = sealed;
    const auto at = edited.find("\"predicted\": \"helps\"");
    REQUIRE(at != std::string::npos);
    edited.replace(at, 20, "\"predicted\": \"fails\"");
    auto v = sentinel::verify_record(edited, "r.json");
    CHECK(v.kind == sentinel::Verification::Edited);
    CHECK(v.message.find("'r.json' was edited after registration") != std::string::npos);

    // One character of a number changed (the first digit of the width).
    edited = sealed;
    const auto w = edited.find("\"width\": 4");
    REQUIRE(w != std::string::npos);
    edited[w + 9] = '5';
    CHECK(sentinel::verify_record(edited, "r.json").kind == sentinel::Verification::Edited);

    // Reformatted (one more space): the exact bytes are hashed.
    edited = sealed;
    edited.insert(1, " ");
    CHECK(sentinel::verify_record(edited, "r.json").kind == sentinel::Verification::Edited);

    // The seal itself changed.
    edited = sealed;
    const auto s = edited.find("\"sha256\": \"", edited.rfind("\"predictions\""));
    REQUIRE(s != std::string::npos);
    edited[s + 11] = edited[s + 11] == '0' ? '1' : '0';
    CHECK(sentinel::verify_record(edited, "r.json").kind == sentinel::Verification::Edited);
}

TEST_CASE("sentinel: verify refuses malformed JSON and missing members and an unknown format version") {
    const std::string sealed = sentinel::seal(sentinel::record_json(small_record()));
    auto kind_of = [](const std::string& t) { return sentinel::verify_record(t, "r.json"); };

    auto v = kind_of(sealed.substr(0, sealed.size() / 2));
    CHECK(v.kind == sentinel::Verification::Malformed);
    CHECK(v.message.find("malformed JSON") != std::string::npos);

    std::string unsealed = sentinel::record_json(small_record());  // no sha256 member
    v = kind_of(unsealed);
    CHECK(v.kind == sentinel::Verification::Malformed);
    CHECK(v.message.find("\"sha256\" is missing") != std::string::npos);

    std::string other = sealed;
    other.replace(other.find("\"format_version\": 1"), 19, "\"format_version\": 7");
    v = kind_of(other);
    CHECK(v.kind == sentinel::Verification::Malformed);
    CHECK(v.message.find("unknown sentinel record format version 7") != std::string::npos);

    std::string no_device = sealed;
    no_device.replace(no_device.find("\"device\""), 8, "\"devicx\"");
    v = kind_of(no_device);
    CHECK(v.kind == sentinel::Verification::Malformed);
    CHECK(v.message.find("\"device\" is missing") != std::string::npos);

    CHECK(kind_of("[1, 2]").kind == sentinel::Verification::Malformed);
    CHECK_FALSE(parse_json("{\"a\": 1, \"a\": 2}"));
    CHECK_FALSE(parse_json("{\"a\": 01}"));
    CHECK(parse_json("{\"a\": [true, null, -1.5e3, \"\\u00e9\"]}"));
}

TEST_CASE("sentinel: a taxonomy's record is version 2, names the taxonomy and keeps its classes' traits") {
    sentinel::Record r = small_record();
    const std::string v1 = sentinel::seal(sentinel::record_json(r));
    CHECK(v1.find("\"format_version\": 1,") != std::string::npos);
    CHECK(v1.find("\"taxonomy\"") == std::string::npos);  // a buckets' record is as before
    r.taxonomy = sentinel::TaxonomyRecord{"/nowhere/t.lpe", sha256_hex("t"), {"caustic", "lamp", "rest", "other"}, {}};
    r.taxonomy->traits.heavy = 0b0001;
    r.taxonomy->traits.constant = 0b0010;
    r.taxonomy->traits.rare = 0b0101;
    CHECK(r.class_names() == std::vector<std::string>{"caustic", "lamp", "rest", "other"});
    const std::string v2 = sentinel::seal(sentinel::record_json(r));
    CHECK(v2.find("\"format_version\": 2,") != std::string::npos);
    CHECK(v2.find("\"heavy\": [\"caustic\"], \"constant\": [\"lamp\"], \"rare\": [\"caustic\", \"rest\"]") !=
          std::string::npos);
    CHECK(sentinel::verify_record(v2, "r.json").kind == sentinel::Verification::Intact);
    const auto doc = parse_json(v2);
    REQUIRE(doc);
    const sentinel::Record b = sentinel::parse_record(*doc);
    REQUIRE(b.taxonomy);
    CHECK(b.taxonomy->path == "/nowhere/t.lpe");
    CHECK(b.taxonomy->sha256 == sha256_hex("t"));
    CHECK(b.class_names() == r.class_names());
    CHECK(b.class_traits().heavy == 0b0001);
    CHECK(b.class_traits().constant == 0b0010);
    CHECK(b.class_traits().rare == 0b0101);
    CHECK_FALSE(sentinel::parse_record(*parse_json(v1)).taxonomy);
    CHECK(sentinel::parse_record(*parse_json(v1)).class_traits().heavy == alloc::ClassTraits{}.heavy);
    // Version 2 without the taxonomy, or version 1 with one, is malformed (a vkmech that reads version 1 only
    // must not evaluate a taxonomy's record by the buckets).
    std::string no_tax = v1;
    no_tax.replace(no_tax.find("\"format_version\": 1"), 19, "\"format_version\": 2");
    auto v = sentinel::verify_record(no_tax, "r.json");
    CHECK(v.kind == sentinel::Verification::Malformed);
    CHECK(v.message.find("the member \"taxonomy\" is missing") != std::string::npos);
    std::string as_v1 = v2;
    as_v1.replace(as_v1.find("\"format_version\": 2"), 19, "\"format_version\": 1");
    v = sentinel::verify_record(as_v1, "r.json");
    CHECK(v.kind == sentinel::Verification::Malformed);
    CHECK(v.message.find("a record with a \"taxonomy\" is format version 2") != std::string::npos);
    std::string not_object = v2;
    const size_t tax_at = not_object.find("\"taxonomy\": {");
    not_object.replace(tax_at, not_object.find('\n', tax_at) - tax_at, "\"taxonomy\": 7,");
    v = sentinel::verify_record(not_object, "r.json");
    CHECK(v.kind == sentinel::Verification::Malformed);
    CHECK(v.message.find("the member \"taxonomy\" has the wrong type") != std::string::npos);
    // A property naming no class is refused when read.
    std::string unknown = v2;
    unknown.replace(unknown.find("\"constant\": [\"lamp\"]"), 20, "\"constant\": [\"lump\"]");
    CHECK_THROWS_WITH_AS(sentinel::parse_record(*parse_json(unknown)), doctest::Contains("taxonomy.constant"),
                         std::runtime_error);
}

TEST_CASE("sentinel: the prediction rules over a pilot diagnosis") {
    const Frame f = synthetic_pilot(10, 10, 0);
    const Pilot pilot = make_pilot(f, {});
    alloc::PilotDiagnosis d = alloc::diagnose_pilot(pilot);
    REQUIRE(d.untrusted == 0);
    REQUIRE(d.floor_abstains);
    auto ps = sentinel::predict(pilot.frame, d, nullptr, nullptr);
    REQUIRE(find(ps, "allocation.observed-var_vs_uniform"));
    CHECK(find(ps, "allocation.observed-var_vs_uniform")->outcome == "helps");
    CHECK(find(ps, "allocation.bucket-floor_vs_observed-var")->outcome == "no-op");
    CHECK(find(ps, "allocation.guarded_vs_bucket-floor")->outcome == "no-op");
    CHECK_FALSE(find(ps, "allocation.robust-var_vs_uniform"));  // no median-of-means given
    CHECK_FALSE(find(ps, "reliability.margin"));                // no curve given
    CHECK_FALSE(find(ps, "structure.rho_CG_sign"));             // no separation given
    REQUIRE(find(ps, "coverage.emitter_direct.pixel_share"));
    CHECK(find(ps, "coverage.emitter_direct.pixel_share")->value == doctest::Approx(1.0));

    // Starved: 5 of 100 pixels untrusted (the threshold), a changed floor.
    d.untrusted = 5;
    d.floor_abstains = false;
    d.floor_changed = 3;
    ps = sentinel::predict(pilot.frame, d, nullptr, nullptr);
    CHECK(find(ps, "allocation.observed-var_vs_uniform")->outcome == "fails");
    CHECK(find(ps, "allocation.bucket-floor_vs_uniform")->outcome == "fails");
    CHECK(find(ps, "allocation.bucket-floor_vs_observed-var")->outcome == "helps");
    CHECK(find(ps, "allocation.guarded_vs_bucket-floor")->outcome == "helps");
    d.untrusted = 4;
    CHECK(find(sentinel::predict(pilot.frame, d, nullptr, nullptr), "allocation.observed-var_vs_uniform")->outcome ==
          "helps");
    CHECK(find(sentinel::predict(pilot.frame, d, nullptr, nullptr), "allocation.guarded_vs_uniform")->outcome ==
          "helps");
    // A pilot shorter than 16 samples per pixel: the pilot-variance strategies, guarded included, fail against uniform.
    const Frame short_pilot = synthetic_pilot(10, 10, 0, 8);
    ps = sentinel::predict(short_pilot, d, nullptr, nullptr);
    CHECK(find(ps, "allocation.observed-var_vs_uniform")->outcome == "fails");
    CHECK(find(ps, "allocation.guarded_vs_uniform")->outcome == "fails");

    // Finding 1: the sign from the mutual visibility.
    SeparationMeasures sep;
    sep.delta_objects = sep.glossy_objects = 1;
    sep.segments = 100;
    sep.mutual_visibility = 0.122;
    CHECK(find(sentinel::predict(pilot.frame, d, nullptr, &sep), "structure.rho_CG_sign")->outcome == "positive");
    sep.mutual_visibility = 0.0;
    CHECK(find(sentinel::predict(pilot.frame, d, nullptr, &sep), "structure.rho_CG_sign")->outcome == "negative");
    sep.glossy_objects = 0;
    CHECK_FALSE(find(sentinel::predict(pilot.frame, d, nullptr, &sep), "structure.rho_CG_sign"));
}

TEST_SUITE("gpu") {
    TEST_CASE("sentinel: register renders only the pilot seed and never a reference or pool seed") {
        VKMECH_REQUIRE_GPU(ctx);
        Scene scene = load_scene(std::string(VKMECH_SOURCE_DIR) + "/scenes/cubes_dof.xml");
        scene.camera.set_film_width(32);
        RenderSession session(*ctx, std::move(scene), Traversal::Bvh);
        Renderer renderer = session.renderer(session.features(Estimator::Nee, true));
        std::vector<uint32_t> seeds;
        const PilotRenderFn recording = [&](uint32_t n0, uint32_t seed, bool robust) {
            seeds.push_back(seed);
            return render_pilot(renderer, n0, seed, robust);
        };
        const sentinel::Record r = register_sentinel(session, recording, 16, 2, nullptr);
        REQUIRE(seeds.size() == 1);
        CHECK(seeds[0] == downstream_seeds::pilot(2));
        for (uint32_t s : seeds) {
            CHECK(s != downstream_seeds::kPool);
            CHECK(s < downstream_seeds::reference_chunk(0));
        }
        REQUIRE(r.renders.size() == 1);
        CHECK(r.renders[0].seed == downstream_seeds::pilot(2));
        CHECK(r.renders[0].spp == 16);
        CHECK(r.diagnosis.pixels == 1024);
        CHECK(r.diagnosis.robust_checked);  // N0 = 16 allows the median of means
        CHECK(find(r.predictions, "allocation.robust-floor_vs_robust-var"));
    }

    TEST_CASE(
        "sentinel: register and evaluate --taxonomy label by the classes, and paper.lpe predicts as the buckets") {
        VKMECH_REQUIRE_GPU(ctx);
        testing::TempDir dir("sentinel_tax");
        const std::string small =
            "sentinel register --scene glass_caustic --res 24 --pilot 8 --reference-spp 64 "
            "--draws 2 --out ";
        const std::string paper = std::string(VKMECH_SOURCE_DIR) + "/taxonomies/paper.lpe";
        // The same lines in reverse order: every class in another slot.
        std::string reversed;
        {
            std::vector<std::string> lines;
            std::istringstream in(read_text(paper));
            for (std::string l; std::getline(in, l);)
                if (!l.empty() && l[0] != '#') lines.insert(lines.begin(), l);
            for (const auto& l : lines) reversed += l + "\n";
        }
        write_text(dir.file("rev.lpe"), reversed);
        struct Run {
            std::map<std::string, JsonValue> predictions, outcomes;
            std::optional<JsonValue> record;
            std::string diagnosis;  // the record's line
        };
        auto run = [&](const std::string& name, const std::string& taxonomy) {
            const std::string rec = dir.file(name + ".json");
            auto r = testing::run_cli(small + rec + (taxonomy.empty() ? "" : " --taxonomy " + taxonomy));
            INFO(r.output);
            REQUIRE(r.code == 0);
            auto e = testing::run_cli("sentinel evaluate " + rec + " --out " + dir.file(name + "_ev"));
            INFO(e.output);
            REQUIRE(e.code == 0);
            Run out;
            const std::string text = read_text(rec);
            out.record = parse_json(text);
            REQUIRE(out.record);
            const size_t at = text.find("\"diagnosis\":");
            REQUIRE(at != std::string::npos);
            out.diagnosis = text.substr(at, text.find('\n', at) - at);
            for (const JsonValue& p : out.record->find("predictions")->array)
                out.predictions[p.find("name")->string] = p;
            const auto ev = parse_json(read_text(dir.file(name + "_ev") + "/evaluation.json"));
            REQUIRE(ev);
            for (const JsonValue& o : ev->find("outcomes")->array) out.outcomes[o.find("name")->string] = o;
            return out;
        };
        const Run b = run("b", ""), p = run("p", paper), rv = run("rv", dir.file("rev.lpe"));
        CHECK(b.record->find("format_version")->number == 1);
        CHECK(p.record->find("format_version")->number == 2);
        CHECK(p.record->find("taxonomy")->find("sha256")->string == sha256_file(paper));
        CHECK(p.record->find("curve")->kind == JsonValue::Null);
        CHECK(rv.record->find("taxonomy")->find("classes")->array[0].string == "specular_direct");
        // Every prediction but the curve's (reliability.*), with the same value or outcome, and the same verdict.
        CHECK(b.predictions.count("reliability.margin") == 1);
        for (const Run* t : {&p, &rv}) {
            CHECK(t->predictions.size() + 2 == b.predictions.size());
            CHECK(t->diagnosis == b.diagnosis);
            for (const auto& entry : t->predictions) {
                const std::string& name = entry.first;
                CAPTURE(name);
                REQUIRE(b.predictions.count(name) == 1);
                const JsonValue &x = *entry.second.find("predicted"), &y = *b.predictions.at(name).find("predicted");
                CHECK(x.kind == y.kind);
                CHECK(x.number == y.number);
                CHECK(x.string == y.string);
                CHECK(t->outcomes.at(name).find("measured")->string == b.outcomes.at(name).find("measured")->string);
                CHECK(t->outcomes.at(name).find("verdict")->string == b.outcomes.at(name).find("verdict")->string);
            }
        }
        CHECK(read_text(dir.file("rv_ev") + "/report.md").find("Labels: the classes of the taxonomy") !=
              std::string::npos);
        // With fewer lines than buckets `other` is not slot 6: the report's `other` energy is the last class's.
        write_text(dir.file("two.lpe"), "caustic [heavy rare] = C .* S .* [LB]\ndirect = C [DG] [LB]\n");
        const Run two = run("two", dir.file("two.lpe"));
        CHECK(two.predictions.count("coverage.other.energy_share") == 1);
        CHECK(two.predictions.count("coverage.glossy.energy_share") == 0);
        CHECK(std::stod(two.outcomes.at("coverage.other.energy_share").find("measured")->string) > 0.1);
        CHECK(read_text(dir.file("two_ev") + "/report.md").find("`other` energy 0,") == std::string::npos);
        // Finding 1's sign reads the buckets' caustic_frac and glossy_frac: a taxonomy's record does not predict it.
        const std::string mixed = "sentinel register --scene tabletop_mixed --res 16 --pilot 4 --out ";
        REQUIRE(testing::run_cli(mixed + dir.file("mb.json")).code == 0);
        REQUIRE(testing::run_cli(mixed + dir.file("mt.json") + " --taxonomy " + paper).code == 0);
        CHECK(read_text(dir.file("mb.json")).find("\"structure.rho_CG_sign\"") != std::string::npos);
        CHECK(read_text(dir.file("mt.json")).find("\"structure.rho_CG_sign\"") == std::string::npos);
        // A taxonomy edited after registration is refused (exit 1), as an edited scene is.
        write_text(dir.file("rev.lpe"), reversed + "# edited\n");
        auto e = testing::run_cli("sentinel evaluate " + dir.file("rv.json") + " --out " + dir.file("rv_ev2"));
        CHECK(e.code == 1);
        CHECK(e.output.find("refusing to evaluate a record of another taxonomy") != std::string::npos);
        // The installed curve was fitted on the buckets: --curve with it and --taxonomy is refused (exit 2).
        e = testing::run_cli(small + dir.file("c.json") + " --taxonomy " + paper + " --curve " + VKMECH_SOURCE_DIR +
                             "/docs/results/predictor_curve.json");
        CHECK(e.code == 2);
        CHECK(e.output.find("was fitted on the paper's buckets, not on a taxonomy's classes") != std::string::npos);
    }

    TEST_CASE("sentinel: register on cubes_dof writes a record that verify accepts and an edited copy is refused") {
        VKMECH_REQUIRE_GPU(ctx);
        testing::TempDir dir("sentinel_cli");
        const std::string rec = dir.file("cubes_dof.sentinel.json");
        auto r = testing::run_cli("sentinel register --scene cubes_dof --res 32 --pilot 16 --out " + rec);
        INFO(r.output);
        REQUIRE(r.code == 0);
        CHECK(r.output.find("the reference is not rendered") != std::string::npos);
        const std::string text = read_text(rec);
        const auto doc = parse_json(text);
        REQUIRE(doc);
        const JsonValue* renders = doc->find("renders");
        REQUIRE(renders);
        REQUIRE(renders->array.size() == 1);
        CHECK(renders->array[0].find("seed")->number == downstream_seeds::pilot(0));
        CHECK(doc->find("scene")->find("sha256")->string ==
              sha256_file(std::string(VKMECH_SOURCE_DIR) + "/scenes/cubes_dof.xml"));
        CHECK(text.find("\"reliability.margin\"") != std::string::npos);

        auto v = testing::run_cli("sentinel verify " + rec);
        INFO(v.output);
        CHECK(v.code == 0);
        CHECK(v.output.find("intact sentinel record of cubes_dof") != std::string::npos);

        // A second registration into the same file is refused (exit 2): a record is never overwritten.
        CHECK(testing::run_cli("sentinel register --scene cubes_dof --res 32 --pilot 16 --out " + rec).code == 2);

        // Evaluate the intact record with a small protocol (registered below): PASS/FAIL per prediction.
        const std::string rec2 = dir.file("small.sentinel.json");
        REQUIRE(testing::run_cli("sentinel register --scene cubes_dof --res 16 --pilot 8 --reference-spp 64 --draws 2 "
                                 "--out " +
                                 rec2)
                    .code == 0);
        const std::string ev = dir.file("ev");
        auto e = testing::run_cli("sentinel evaluate " + rec2 + " --out " + ev);
        INFO(e.output);
        REQUIRE(e.code == 0);
        const auto evdoc = parse_json(read_text(ev + "/evaluation.json"));
        REQUIRE(evdoc);
        const auto recdoc = parse_json(read_text(rec2));
        REQUIRE(recdoc);
        CHECK(evdoc->find("outcomes")->array.size() == recdoc->find("predictions")->array.size());
        CHECK(evdoc->find("record")->find("sha256")->string == recdoc->find("sha256")->string);
        CHECK(evdoc->find("summary")->find("pilot_reproduced")->boolean);
        CHECK(read_text(ev + "/report.md").find("| allocation.observed-var_vs_uniform | fails |") != std::string::npos);
        // An existing evaluation is not overwritten without --force.
        CHECK(testing::run_cli("sentinel evaluate " + rec2 + " --out " + ev).code == 2);

        // A record of a scene that changed after registration is refused (exit 1).
        const std::string scene_copy = dir.file("copy.xml");
        std::filesystem::copy_file(std::string(VKMECH_SOURCE_DIR) + "/scenes/cubes_dof.xml", scene_copy);
        const std::string rec3 = dir.file("copy.sentinel.json");
        REQUIRE(testing::run_cli("sentinel register --scene " + scene_copy +
                                 " --res 16 --pilot 8 --reference-spp 64 "
                                 "--draws 1 --out " +
                                 rec3)
                    .code == 0);
        write_text(scene_copy, read_text(scene_copy) + "<!-- edited -->\n");
        e = testing::run_cli("sentinel evaluate " + rec3 + " --out " + dir.file("ev3"));
        CHECK(e.code == 1);
        CHECK(e.output.find("changed since registration") != std::string::npos);

        std::string edited = text;
        const auto at = edited.find("\"pilot_spp\": 16");
        REQUIRE(at != std::string::npos);
        edited.replace(at, 15, "\"pilot_spp\": 64");
        write_text(rec, edited);
        v = testing::run_cli("sentinel verify " + rec);
        CHECK(v.code == 1);
        CHECK(v.output.find("was edited after registration") != std::string::npos);
        CHECK(v.output.find(rec) != std::string::npos);
        // evaluate refuses it too, before rendering anything.
        e = testing::run_cli("sentinel evaluate " + rec + " --out " + dir.file("ev2"));
        CHECK(e.code == 1);
        CHECK(e.output.find("refusing to evaluate") != std::string::npos);
        CHECK_FALSE(std::filesystem::exists(dir.file("ev2") + "/cache"));
    }
}
