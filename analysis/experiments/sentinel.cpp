#include "experiments/sentinel.hpp"

#include "allocation/mom.hpp"
#include "io/invariant.hpp"
#include "io/json.hpp"
#include "io/json_value.hpp"
#include "io/sha256.hpp"
#include "render/descriptor.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <sstream>
#include <stdexcept>

namespace vkmech::sentinel {

namespace {

// How evaluate decides a categorical prediction (docs/descriptor.md §9.4).
std::string pass_rule(const std::string& name, const std::string& what) {
    if (name.rfind("allocation.", 0) == 0) {
        const std::string pair = name.substr(11);
        const size_t vs = pair.find("_vs_");
        const std::string a = pair.substr(0, vs), b = vs == std::string::npos ? "?" : pair.substr(vs + 4);
        const std::string over =
            " over the protocol's pilot draws (equal samples: the protocol's extra budget and floor, "
            "final images from the shared pool, PSNR on unclamped RGB against the reference)";
        const std::string share = json_number(kWinShare);
        if (what == "helps")
            return "PASS if " + a + "'s mean PSNR is above " + b + "'s and its MSE is lower on at least " + share +
                   " of the draws, FAIL if its mean PSNR is not above, INDETERMINATE otherwise" + over;
        if (what == "fails")
            return "PASS if " + a + "'s mean PSNR is below " + b + "'s and its MSE is higher on at least " + share +
                   " of the draws, FAIL if its mean PSNR is not below, INDETERMINATE otherwise" + over;
        if (what == "no-op")
            return "PASS if " + a + "'s allocation equals " + b + "'s bit for bit on the registered draw";
    }
    if (name == "structure.rho_CG_sign")
        return "PASS if the 95% tile-bootstrap interval of rho (8x8-pixel tiles, 1000 resamples, seed 0) lies on the "
               "predicted side of 0, FAIL if it lies on the other side, INDETERMINATE if it contains 0 or rho is "
               "undefined";
    return "";
}

Prediction outcome(std::string name, std::string what, std::string covers, std::string rule) {
    std::string pass = pass_rule(name, what);
    return {std::move(name), std::move(what), 0.0, std::move(covers), std::move(rule), std::move(pass)};
}

}  // namespace

std::vector<std::string> Record::class_names() const {
    return taxonomy ? taxonomy->classes : std::vector<std::string>(kBucketNames.begin(), kBucketNames.end());
}

std::vector<Prediction> predict(const Frame& pilot, const alloc::PilotDiagnosis& d, const ReliabilityCurve* curve,
                                const SeparationMeasures* sep, const std::vector<std::string>& classes) {
    std::vector<Prediction> out;
    const std::string all_px = "all " + std::to_string(d.pixels) + " pixels";

    // (a) Label reliability from the frozen curve: a statement about the labelled pilot pixels only.
    if (curve) {
        const PilotPrediction p = predict_from_pilot(*curve, pilot);
        const std::string covers = std::to_string(p.labelled) + " pilot-labelled pixels of " + std::to_string(d.pixels);
        const std::string band =
            curve->taxonomy_sha256.empty()
                ? " (the curve's largest first-party leave-one-scene-out error, rounded up)"
                : " (the band of the buckets' frozen curve, its largest first-party leave-one-scene-out error rounded "
                  "up; not derived for this taxonomy's curve)";
        const std::string pass = "PASS if |measured - predicted| <= " + json_number(kReliabilityTolerance) + band +
                                 "; measured: the share of the pixels labelled in both the registered pilot and the "
                                 "reference whose dominant labels agree (§5 agreement)";
        out.push_back({"reliability.margin", "", p.margin, covers,
                       "mean of the frozen margin curve over the pilot-labelled pixels' argmax margins (§5.6)", pass,
                       kReliabilityTolerance});
        out.push_back({"reliability.purity", "", p.purity, covers,
                       "mean of the frozen purity curve over the pilot-labelled pixels' purities (§5.6)", pass,
                       kReliabilityTolerance});
    }

    // (b) Per-bucket (or per-class) coverage of the pilot (§3.2 summary): predicted to hold at the reference.
    const Descriptor desc = derive_descriptor(pilot);
    const DescriptorSummary s = summarize(pilot, desc);
    const bool by_class = !classes.empty();
    const size_t slots = by_class ? std::min<size_t>(classes.size(), kBucketCount) : kBucketCount;
    for (uint32_t b = 0; b < slots; ++b) {
        const std::string bucket = by_class ? classes[b] : kBucketNames[b];
        const std::string kind = by_class ? "class " : "bucket ";
        const std::string band = "PASS if |measured - predicted| <= " + json_number(kShareTolerance) + "; measured: ";
        out.push_back({"coverage." + bucket + ".pixel_share", "", s.pixel_share[b],
                       std::to_string(s.labelled_pixels) + " pilot-labelled pixels",
                       "the pilot's share of labelled pixels whose dominant " + kind + "is " + bucket,
                       band + "the same share in the reference", kShareTolerance});
        out.push_back({"coverage." + bucket + ".energy_share", "", s.energy_share[b], all_px,
                       "the pilot's share of the image energy in " + kind + bucket,
                       band + "the same share in the reference", kShareTolerance});
    }

    // (c) Allocation strategies (§6), from the pilot diagnosis (§6.5).
    char share[160];
    std::snprintf(share, sizeof share, "%zu of %zu pixels untrusted (%.4f; threshold %.2f)", d.untrusted, d.pixels,
                  d.untrusted_share(), kUntrustedFailShare);
    const uint64_t n0 = d.pixels > 0 ? pilot.samples / d.pixels : 0;  // the pilot's samples per pixel
    const bool short_pilot = n0 < kPilotFailBelowSpp;
    const bool starved = (d.pixels > 0 && d.untrusted_share() >= kUntrustedFailShare) || short_pilot;
    const std::string n0_rule = "fails if the pilot has fewer than " + std::to_string(kPilotFailBelowSpp) +
                                " samples per pixel (this one: " + std::to_string(n0) +
                                "; first-party evidence: observed-var below uniform on 5 of 7 scenes at N0 = 4, above "
                                "on 6 of 7 at N0 = 16)";
    const std::string var_rule =
        n0_rule + " or the untrusted share is at least " + json_number(kUntrustedFailShare) +
        " (the ajar-door mode: the pilot leaves pixels it cannot vouch for with the floor only), helps otherwise; " +
        share;
    out.push_back(outcome("allocation.observed-var_vs_uniform", starved ? "fails" : "helps", all_px, var_rule));
    out.push_back(outcome("allocation.bucket-floor_vs_uniform", starved ? "fails" : "helps", all_px, var_rule));
    out.push_back(outcome(
        "allocation.bucket-floor_vs_observed-var", d.floor_abstains ? "no-op" : "helps", all_px,
        "no-op if the floor changes no pilot pixel's score (identical allocation, bit for bit), helps otherwise (" +
            std::to_string(d.heavy) + " heavy-tailed pilot pixels, " + std::to_string(d.floor_changed) + " changed)"));
    if (d.robust_checked) {
        out.push_back(outcome("allocation.robust-var_vs_uniform", starved ? "fails" : "helps", all_px, var_rule));
        out.push_back(outcome("allocation.robust-floor_vs_robust-var", d.robust_floor_abstains ? "no-op" : "helps",
                              all_px,
                              "no-op if the floor changes no pilot pixel's median-of-means score, helps otherwise (" +
                                  std::to_string(d.robust_floor_changed) + " changed)"));
    }
    out.push_back(
        outcome("allocation.guarded_vs_bucket-floor", d.untrusted == 0 ? "no-op" : "helps", all_px,
                std::string("no-op if no pilot pixel is untrusted (identical allocation), helps otherwise; ") + share));
    out.push_back(outcome("allocation.guarded_vs_uniform", short_pilot ? "fails" : "helps", all_px,
                          n0_rule + ", helps otherwise: guarded keeps at least the uniform share where the pilot "
                                    "cannot be trusted, so only the pilot's length is held against it"));

    // (d) Finding 1: the sign of rho(C, G) from the families' mutual visibility.
    if (sep && sep->defined() && std::isfinite(sep->mutual_visibility)) {
        const bool sees = sep->mutual_visibility >= kVisibilitySignThreshold;
        out.push_back(outcome("structure.rho_CG_sign", sees ? "positive" : "negative",
                              "the reference's labelled pixels (Spearman rho of caustic_frac and glossy_frac, §5.4)",
                              "positive if the delta-S and glossy families' mutual visibility is at least " +
                                  json_number(kVisibilitySignThreshold) + ", negative otherwise; measured " +
                                  json_number(sep->mutual_visibility) + " over " + std::to_string(sep->segments) +
                                  " segments (Finding 1)"));
    }
    return out;
}

std::string record_json(const Record& r) {
    const alloc::PilotDiagnosis& d = r.diagnosis;
    std::ostringstream j;
    j << "{\n  \"format\": " << json_string(kFormat)
      << ",\n  \"format_version\": " << (r.taxonomy ? kTaxonomyFormatVersion : kFormatVersion);
    j << ",\n  \"scene\": {\"name\": " << json_string(r.scene_name) << ", \"path\": " << json_string(r.scene_path)
      << ", \"sha256\": " << json_string(r.scene_sha256) << ", \"files\": [";
    for (size_t i = 0; i < r.scene_files.size(); ++i)
        j << (i ? ", " : "") << "{\"path\": " << json_string(r.scene_files[i].path)
          << ", \"sha256\": " << json_string(r.scene_files[i].sha256) << "}";
    j << "], \"params\": {";
    size_t pi = 0;
    for (const auto& [k, v] : r.params) j << (pi++ ? ", " : "") << json_string(k) << ": " << json_string(v);
    j << "}}";
    j << ",\n  \"settings\": {\"width\": " << r.width << ", \"height\": " << r.height
      << ", \"pilot_spp\": " << r.pilot_spp << ", \"pilot_draw\": " << r.pilot_draw
      << ", \"pilot_seed\": " << r.pilot_seed << ", \"estimator\": " << json_string(r.estimator)
      << ", \"end_vertex\": " << json_string(r.end_vertex)
      << ", \"light_selection\": " << json_string(r.light_selection) << ", \"max_depth\": " << r.max_depth
      << ", \"rr_depth\": " << r.rr_depth << ", \"traversal\": " << json_string(r.traversal) << "}";
    j << ",\n  \"protocol\": {\"reference_spp\": " << r.protocol.reference_spp << ", \"draws\": " << r.protocol.draws
      << ", \"extra_spp\": " << r.protocol.extra_spp << ", \"floor\": " << r.protocol.floor << "}";
    if (r.taxonomy) {
        const TaxonomyRecord& t = *r.taxonomy;
        auto names = [&](uint32_t bits) {
            std::string list;
            for (size_t c = 0; c < t.classes.size(); ++c)
                if ((bits >> c) & 1u) list += (list.empty() ? "" : ", ") + json_string(t.classes[c]);
            return "[" + list + "]";
        };
        j << ",\n  \"taxonomy\": {\"path\": " << json_string(t.path) << ", \"sha256\": " << json_string(t.sha256)
          << ", \"classes\": [";
        for (size_t c = 0; c < t.classes.size(); ++c) j << (c ? ", " : "") << json_string(t.classes[c]);
        j << "], \"heavy\": " << names(t.traits.heavy) << ", \"constant\": " << names(t.traits.constant)
          << ", \"rare\": " << names(t.traits.rare) << "}";
    }
    j << ",\n  \"renders\": [";
    for (size_t i = 0; i < r.renders.size(); ++i)
        j << (i ? ", " : "") << "{\"purpose\": \"pilot\", \"seed\": " << r.renders[i].seed
          << ", \"spp\": " << r.renders[i].spp << "}";
    j << "]";
    j << ",\n  \"code\": {\"version\": " << json_string(r.version)
      << ", \"code_digest\": " << json_string(r.code_digest) << ", \"spirv_sha256\": " << json_string(r.spirv_sha256)
      << "}";
    j << ",\n  \"registered_utc\": " << json_string(r.registered_utc);
    j << ",\n  \"device\": " << json_string(r.device);
    j << ",\n  \"curve\": ";
    if (r.curve_path.empty())
        j << "null";
    else
        j << "{\"path\": " << json_string(r.curve_path) << ", \"sha256\": " << json_string(r.curve_sha256)
          << ", \"pilot_spp\": " << r.curve_pilot_spp << ", \"reference_spp\": " << r.curve_reference_spp << "}";
    j << ",\n  \"diagnosis\": {\"pixels\": " << d.pixels << ", \"labelled\": " << d.labelled << ", \"seen\": " << d.seen
      << ", \"heavy\": " << d.heavy << ", \"floor_changed\": " << d.floor_changed
      << ", \"floor_abstains\": " << (d.floor_abstains ? "true" : "false");
    if (d.robust_checked)
        j << ", \"robust_floor_changed\": " << d.robust_floor_changed
          << ", \"robust_floor_abstains\": " << (d.robust_floor_abstains ? "true" : "false");
    j << ", \"untrusted\": " << d.untrusted << ", \"lit_no_variance\": " << d.lit_no_variance
      << ", \"dark_in_lit_region\": " << d.dark_in_lit_region << "}";
    j << ",\n  \"separation\": ";
    if (!r.separation)
        j << "null";
    else
        j << "{\"delta_objects\": " << r.separation->delta_objects
          << ", \"glossy_objects\": " << r.separation->glossy_objects
          << ", \"min_distance\": " << json_number(r.separation->min_distance)
          << ", \"mutual_visibility\": " << json_number(r.separation->mutual_visibility)
          << ", \"segments\": " << r.separation->segments << ", \"visible\": " << r.separation->visible << "}";
    j << ",\n  \"predictions\": [";
    for (size_t i = 0; i < r.predictions.size(); ++i) {
        const Prediction& p = r.predictions[i];
        j << (i ? "," : "") << "\n    {\"name\": " << json_string(p.name)
          << ", \"predicted\": " << (p.outcome.empty() ? json_number(p.value) : json_string(p.outcome))
          << ", \"covers\": " << json_string(p.covers) << ", \"tolerance\": " << json_number(p.tolerance)
          << ", \"rule\": " << json_string(p.rule) << ", \"pass_if\": " << json_string(p.pass_if) << "}";
    }
    j << "\n  ]\n}\n";
    return j.str();
}

namespace {
const std::string kTail = "\n}\n";
const std::string kSealKey = ",\n  \"sha256\": \"";
constexpr size_t kHexLen = 64;
}  // namespace

std::string seal(const std::string& body) {
    VKM_ASSERT(body.size() >= kTail.size() && body.compare(body.size() - kTail.size(), kTail.size(), kTail) == 0,
               "sentinel::seal: the body must end with \"\\n}\\n\" (record_json writes it so)");
    return body.substr(0, body.size() - kTail.size()) + kSealKey + sha256_hex(body) + "\"" + kTail;
}

Verification verify_record(const std::string& text, const std::string& file) {
    const std::string f = "'" + file + "'";
    auto bad = [&](const std::string& why) {
        return Verification{Verification::Malformed, f + " is not a sentinel record: " + why};
    };
    std::string why;
    const std::optional<JsonValue> doc = parse_json(text, &why);
    if (!doc) return bad("malformed JSON: " + why);
    if (doc->kind != JsonValue::Object) return bad("the top level is not a JSON object");
    const JsonValue* format = doc->find("format");
    if (!format || format->kind != JsonValue::String || format->string != kFormat)
        return bad(std::string("it lacks \"format\": \"") + kFormat + "\"");
    const JsonValue* version = doc->find("format_version");
    if (!version || version->kind != JsonValue::Number) return bad("it lacks a numeric \"format_version\"");
    if (version->number != kFormatVersion && version->number != kTaxonomyFormatVersion)
        return {Verification::Malformed, f + ": unknown sentinel record format version " +
                                             json_number(version->number) + " (this vkmech reads versions " +
                                             std::to_string(kFormatVersion) + " and " +
                                             std::to_string(kTaxonomyFormatVersion) + ")"};
    const JsonValue* tax = doc->find("taxonomy");
    if (version->number == kTaxonomyFormatVersion && !tax)
        return bad("format version 2 is a taxonomy's record, and the member \"taxonomy\" is missing");
    if (version->number == kTaxonomyFormatVersion && tax->kind != JsonValue::Object)
        return bad("the member \"taxonomy\" has the wrong type");
    if (version->number == kFormatVersion && tax) return bad("a record with a \"taxonomy\" is format version 2");
    struct Required {
        const char* key;
        JsonValue::Kind kind;
    };
    for (const Required& r : {Required{"scene", JsonValue::Object},
                              {"settings", JsonValue::Object},
                              {"protocol", JsonValue::Object},
                              {"renders", JsonValue::Array},
                              {"code", JsonValue::Object},
                              {"registered_utc", JsonValue::String},
                              {"device", JsonValue::String},
                              {"diagnosis", JsonValue::Object},
                              {"predictions", JsonValue::Array},
                              {"sha256", JsonValue::String}}) {
        const JsonValue* v = doc->find(r.key);
        if (!v) return bad(std::string("the member \"") + r.key + "\" is missing");
        if (v->kind != r.kind) return bad(std::string("the member \"") + r.key + "\" has the wrong type");
    }
    for (const JsonValue& p : doc->find("predictions")->array)
        if (p.kind != JsonValue::Object || !p.find("name") || !p.find("predicted") || !p.find("rule"))
            return bad("a prediction lacks its \"name\", \"predicted\" or \"rule\"");
    const std::string& recorded = doc->find("sha256")->string;
    if (recorded.size() != kHexLen || recorded.find_first_not_of("0123456789abcdef") != std::string::npos)
        return bad("\"sha256\" is not 64 lowercase hex digits");

    const std::string edited = f + " was edited after registration: ";
    // The seal is the last member, written exactly as seal() writes it (canonical form, sentinel.hpp).
    const std::string suffix = kSealKey + recorded + "\"" + kTail;
    if (text.size() < suffix.size() || text.compare(text.size() - suffix.size(), suffix.size(), suffix) != 0)
        return {Verification::Edited, edited + "its \"sha256\" member is no longer the last line as registered"};
    const std::string body = text.substr(0, text.size() - suffix.size()) + kTail;
    const std::string actual = sha256_hex(body);
    if (actual != recorded)
        return {Verification::Edited,
                edited + "its content hashes to " + actual + ", the registered SHA-256 is " + recorded};

    const JsonValue* scene = doc->find("scene")->find("name");
    return {Verification::Intact, f + ": intact sentinel record of " +
                                      (scene && scene->kind == JsonValue::String ? scene->string : "?") +
                                      ", registered " + doc->find("registered_utc")->string + ", " +
                                      std::to_string(doc->find("predictions")->array.size()) + " predictions, sha256 " +
                                      recorded.substr(0, 16) + "..."};
}

namespace {

const JsonValue& member(const JsonValue& o, const std::string& key, JsonValue::Kind kind, const std::string& where) {
    const JsonValue* v = o.kind == JsonValue::Object ? o.find(key) : nullptr;
    if (!v) throw std::runtime_error("sentinel record: " + where + " lacks \"" + key + "\"");
    if (v->kind != kind) throw std::runtime_error("sentinel record: " + where + "." + key + " has the wrong type");
    return *v;
}
std::string text(const JsonValue& o, const std::string& key, const std::string& where) {
    return member(o, key, JsonValue::String, where).string;
}
double number(const JsonValue& o, const std::string& key, const std::string& where) {
    return member(o, key, JsonValue::Number, where).number;
}
uint32_t count(const JsonValue& o, const std::string& key, const std::string& where) {
    const double x = number(o, key, where);
    if (!(x >= 0.0 && x <= 4294967295.0) || x != std::floor(x))
        throw std::runtime_error("sentinel record: " + where + "." + key + " is not a count");
    return static_cast<uint32_t>(x);
}
bool flag(const JsonValue& o, const std::string& key, const std::string& where) {
    return member(o, key, JsonValue::Bool, where).boolean;
}

}  // namespace

Record parse_record(const JsonValue& doc) {
    Record r;
    const JsonValue& scene = member(doc, "scene", JsonValue::Object, "the record");
    r.scene_name = text(scene, "name", "scene");
    r.scene_path = text(scene, "path", "scene");
    r.scene_sha256 = text(scene, "sha256", "scene");
    for (const JsonValue& f : member(scene, "files", JsonValue::Array, "scene").array)
        r.scene_files.push_back({text(f, "path", "scene.files"), text(f, "sha256", "scene.files")});
    for (const auto& [k, v] : member(scene, "params", JsonValue::Object, "scene").object) {
        if (v.kind != JsonValue::String)
            throw std::runtime_error("sentinel record: scene.params." + k + " is not a string");
        r.params[k] = v.string;
    }
    const JsonValue& st = member(doc, "settings", JsonValue::Object, "the record");
    r.width = static_cast<int>(count(st, "width", "settings"));
    r.height = static_cast<int>(count(st, "height", "settings"));
    r.pilot_spp = count(st, "pilot_spp", "settings");
    r.pilot_draw = count(st, "pilot_draw", "settings");
    r.pilot_seed = count(st, "pilot_seed", "settings");
    r.estimator = text(st, "estimator", "settings");
    r.end_vertex = text(st, "end_vertex", "settings");
    r.light_selection = text(st, "light_selection", "settings");
    r.max_depth = static_cast<int>(count(st, "max_depth", "settings"));
    r.rr_depth = static_cast<int>(count(st, "rr_depth", "settings"));
    r.traversal = text(st, "traversal", "settings");
    const JsonValue& pr = member(doc, "protocol", JsonValue::Object, "the record");
    r.protocol.reference_spp = count(pr, "reference_spp", "protocol");
    r.protocol.draws = count(pr, "draws", "protocol");
    r.protocol.extra_spp = count(pr, "extra_spp", "protocol");
    r.protocol.floor = count(pr, "floor", "protocol");
    for (const JsonValue& c : member(doc, "renders", JsonValue::Array, "the record").array)
        r.renders.push_back({count(c, "seed", "renders"), count(c, "spp", "renders")});
    const JsonValue& code = member(doc, "code", JsonValue::Object, "the record");
    r.version = text(code, "version", "code");
    r.code_digest = text(code, "code_digest", "code");
    r.spirv_sha256 = text(code, "spirv_sha256", "code");
    r.registered_utc = text(doc, "registered_utc", "the record");
    r.device = text(doc, "device", "the record");
    if (const JsonValue* c = doc.find("curve"); c && c->kind == JsonValue::Object) {
        r.curve_path = text(*c, "path", "curve");
        r.curve_sha256 = text(*c, "sha256", "curve");
        r.curve_pilot_spp = count(*c, "pilot_spp", "curve");
        r.curve_reference_spp = count(*c, "reference_spp", "curve");
    }
    const JsonValue& d = member(doc, "diagnosis", JsonValue::Object, "the record");
    r.diagnosis.pixels = count(d, "pixels", "diagnosis");
    r.diagnosis.labelled = count(d, "labelled", "diagnosis");
    r.diagnosis.seen = count(d, "seen", "diagnosis");
    r.diagnosis.heavy = count(d, "heavy", "diagnosis");
    r.diagnosis.floor_changed = count(d, "floor_changed", "diagnosis");
    r.diagnosis.floor_abstains = flag(d, "floor_abstains", "diagnosis");
    if (d.find("robust_floor_changed")) {
        r.diagnosis.robust_checked = true;
        r.diagnosis.robust_floor_changed = count(d, "robust_floor_changed", "diagnosis");
        r.diagnosis.robust_floor_abstains = flag(d, "robust_floor_abstains", "diagnosis");
    }
    r.diagnosis.untrusted = count(d, "untrusted", "diagnosis");
    r.diagnosis.lit_no_variance = count(d, "lit_no_variance", "diagnosis");
    r.diagnosis.dark_in_lit_region = count(d, "dark_in_lit_region", "diagnosis");
    if (const JsonValue* s = doc.find("separation"); s && s->kind == JsonValue::Object) {
        SeparationMeasures m;
        m.delta_objects = static_cast<int>(count(*s, "delta_objects", "separation"));
        m.glossy_objects = static_cast<int>(count(*s, "glossy_objects", "separation"));
        const JsonValue* md = s->find("min_distance");
        m.min_distance = md && md->kind == JsonValue::Number ? md->number : NAN;
        const JsonValue* mv = s->find("mutual_visibility");
        m.mutual_visibility = mv && mv->kind == JsonValue::Number ? mv->number : NAN;
        m.segments = count(*s, "segments", "separation");
        m.visible = count(*s, "visible", "separation");
        r.separation = m;
    }
    if (const JsonValue* t = doc.find("taxonomy"); t && t->kind == JsonValue::Object) {
        TaxonomyRecord tr;
        tr.path = text(*t, "path", "taxonomy");
        tr.sha256 = text(*t, "sha256", "taxonomy");
        for (const JsonValue& c : member(*t, "classes", JsonValue::Array, "taxonomy").array) {
            if (c.kind != JsonValue::String)
                throw std::runtime_error("sentinel record: taxonomy.classes holds a non-string");
            tr.classes.push_back(c.string);
        }
        if (tr.classes.empty() || tr.classes.size() > kBucketCount)
            throw std::runtime_error("sentinel record: taxonomy.classes has " + std::to_string(tr.classes.size()) +
                                     " classes (1 to " + std::to_string(kBucketCount) + ")");
        auto bits = [&](const std::string& key) {
            uint32_t b = 0;
            for (const JsonValue& n : member(*t, key, JsonValue::Array, "taxonomy").array) {
                if (n.kind != JsonValue::String)
                    throw std::runtime_error("sentinel record: taxonomy." + key + " holds a non-string");
                const auto at = std::find(tr.classes.begin(), tr.classes.end(), n.string);
                if (at == tr.classes.end())
                    throw std::runtime_error("sentinel record: taxonomy." + key + " names no class ('" + n.string +
                                             "')");
                b |= 1u << (at - tr.classes.begin());
            }
            return b;
        };
        tr.traits.heavy = bits("heavy");
        tr.traits.constant = bits("constant");
        tr.traits.rare = bits("rare");
        r.taxonomy = std::move(tr);
    }
    for (const JsonValue& p : member(doc, "predictions", JsonValue::Array, "the record").array) {
        Prediction x;
        x.name = text(p, "name", "a prediction");
        const JsonValue& v = p.find("predicted") ? *p.find("predicted") : JsonValue();
        if (v.kind == JsonValue::String)
            x.outcome = v.string;
        else if (v.kind == JsonValue::Number)
            x.value = v.number;
        else
            x.value = NAN;  // written as null: not finite
        x.covers = text(p, "covers", "a prediction");
        x.rule = text(p, "rule", "a prediction");
        x.pass_if = text(p, "pass_if", "a prediction");
        if (const JsonValue* t = p.find("tolerance"); t && t->kind == JsonValue::Number) x.tolerance = t->number;
        r.predictions.push_back(std::move(x));
    }
    return r;
}

}  // namespace vkmech::sentinel
