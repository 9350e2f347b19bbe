// Sentinel pre-registration records (paper §8; docs/descriptor.md §9):
// what a pilot alone predicts about a scene, written down and sealed with a
// SHA-256 before any reference is rendered.
//
// predict() is a pure function of the pilot (its frame), the pilot's
// diagnosis (allocation/guard.hpp), the frozen reliability curve and the
// scene's separation measures: nothing here renders, and nothing it reads
// comes from a reference. The app layer (adaptive/sentinel.hpp) renders the
// pilot and the separation segments and fills a Record; seal() writes it;
// verify_record() checks a written one.
//
// Canonical form: a record file is the record's JSON object written without
// its "sha256" member (body B: "{\n" ... "\n}\n", members in the order of
// record_json), with the line `,\n  "sha256": "<H>"` inserted before the final
// "\n}\n", where H = SHA-256(B) in lowercase hex. So the hashed bytes are
// exactly the file minus that one member; any byte changed elsewhere, a
// reformatting included, breaks the seal.
#pragma once

#include "allocation/guard.hpp"
#include "experiments/predictor.hpp"
#include "experiments/separation.hpp"
#include "io/json_value.hpp"
#include "render/frame.hpp"

#include <limits>
#include <map>
#include <optional>
#include <string>
#include <vector>

namespace vkmech::sentinel {

inline constexpr const char* kFormat = "vkmech sentinel record";
inline constexpr int kFormatVersion = 1;
// A record whose pilot a user taxonomy labelled (`sentinel register --taxonomy`, docs/lpe.md) is version
// 2, so that a vkmech reading version 1 only refuses it rather than evaluate it by the buckets.
inline constexpr int kTaxonomyFormatVersion = 2;

// The written-down thresholds of the prediction rules (docs/descriptor.md §9.3).
// A pilot-variance strategy is predicted to fail against uniform when at
// least this share of the pixels is untrusted (§6.5): the ajar-door mode.
inline constexpr double kUntrustedFailShare = 0.05;
// A pilot-variance strategy is also predicted to fail against uniform when the
// pilot has fewer samples per pixel than this: in the committed first-party
// study (docs/results/allocation) observed-var is below uniform on 5 of 7
// scenes at N0 = 4 and above it on 6 of 7 at N0 = 16.
inline constexpr uint32_t kPilotFailBelowSpp = 16;
// rho(C, G) is predicted positive when the delta-S and glossy families' mutual
// visibility is at least this, negative below it (Finding 1; anchors:
// tabletop_mixed 0.122 -> +0.278, tabletop_separated 0.000 -> -0.681).
inline constexpr double kVisibilitySignThreshold = 0.05;
// Pass bands of the numeric predictions, fixed before any sentinel render.
// Label reliability: the frozen curve's largest leave-one-scene-out error on
// the first-party scenes (docs/results/tables/predictor.md: 0.089 margin,
// 0.066 purity), rounded up to one band for both.
inline constexpr double kReliabilityTolerance = 0.09;
// Per-bucket coverage (pixel and energy shares): an absolute band.
inline constexpr double kShareTolerance = 0.05;
// An allocation comparison is decided as the paper decides its own (≥ 8/10
// paired wins and a mean gain): "helps" passes when the mean PSNR gain is
// positive and the treatment has the lower MSE on at least this share of the
// pilot draws; "fails" mirrors it (a negative mean gain, the higher MSE on at
// least this share). The right sign on fewer draws is INDETERMINATE; the
// wrong sign of the mean gain is FAIL.
inline constexpr double kWinShare = 0.8;

struct Prediction {
    std::string name;     // e.g. "allocation.observed-var_vs_uniform"
    std::string outcome;  // a categorical prediction ("helps", "no-op", "fails", "positive", ...); empty for a number
    double value = 0.0;   // a numeric prediction (when outcome is empty)
    std::string covers;   // what the prediction speaks of (e.g. "412 pilot-labelled pixels of 1024")
    std::string rule;     // the rule that produced it
    std::string pass_if;  // how `sentinel evaluate` decides PASS / FAIL, written before any reference exists
    double tolerance = std::numeric_limits<double>::quiet_NaN();  // the pass band of a numeric prediction
};

// Every prediction the pilot supports (docs/descriptor.md §9.3): label
// reliability (when a curve is given), per-bucket pilot coverage, the
// allocation strategies' outcomes (the robust ones when diag.robust_checked),
// and the sign of rho(C, G) when both families exist (sep defined).
// `classes`: the names of the pilot's label slots, for the coverage predictions (empty: the buckets').
std::vector<Prediction> predict(const Frame& pilot, const alloc::PilotDiagnosis& diag, const ReliabilityCurve* curve,
                                const SeparationMeasures* sep, const std::vector<std::string>& classes = {});

struct FileDigest {
    std::string path, sha256;
};

// The taxonomy a record's pilot was labelled by: its file, named by path and SHA-256 as the scene is,
// its classes (the lines', then `other`, slot order) and the classes its lines declare [heavy],
// [constant] and [rare] (a bit per class), which the allocation rules read.
struct TaxonomyRecord {
    std::string path, sha256;
    std::vector<std::string> classes;
    alloc::ClassTraits traits;
};

struct Record {
    std::string scene_name, scene_path, scene_sha256;
    std::map<std::string, std::string> params;  // -D name=value the scene was loaded with
    std::vector<FileDigest> scene_files;        // further files the loader read (textures)
    int width = 0, height = 0;
    uint32_t pilot_spp = 0, pilot_draw = 0, pilot_seed = 0;
    std::string estimator, end_vertex, light_selection, traversal;
    int max_depth = 0, rr_depth = 0;
    struct RenderCall {
        uint32_t seed = 0, spp = 0;
    };
    std::vector<RenderCall> renders;  // every render made before registration: the pilot only
    std::string version, code_digest, spirv_sha256;
    std::string registered_utc;  // ISO 8601, "2025-01-01T12:00:00Z"
    std::string device;
    std::string curve_path, curve_sha256;
    uint32_t curve_pilot_spp = 0, curve_reference_spp = 0;
    // The evaluation protocol, fixed at registration (docs/descriptor.md §9.4):
    // the reference's samples per pixel, the pilot draws compared (the
    // registered one first), and the allocation's extra budget and floor.
    struct Protocol {
        uint32_t reference_spp = 2048, draws = 10, extra_spp = 32, floor = 1;
    } protocol;
    alloc::PilotDiagnosis diagnosis;
    std::optional<SeparationMeasures> separation;
    std::vector<Prediction> predictions;
    std::optional<TaxonomyRecord> taxonomy;  // none: the seven buckets (a version-1 record)
    // The labels' names (the taxonomy's classes, else the buckets') and their traits.
    std::vector<std::string> class_names() const;
    alloc::ClassTraits class_traits() const { return taxonomy ? taxonomy->traits : alloc::ClassTraits{}; }
};

// The record's JSON without the "sha256" member (the canonical body B above).
std::string record_json(const Record& r);
// The record read back from a verified file (the inverse of record_json for
// every member `sentinel evaluate` needs). Throws std::runtime_error naming
// the member that is missing or of the wrong type.
Record parse_record(const JsonValue& doc);

// The sealed file content: B with the "sha256" member. B is record_json's
// output, which ends with "\n}\n" (else InternalError).
std::string seal(const std::string& body);

struct Verification {
    enum Kind { Intact, Edited, Malformed } kind = Malformed;
    std::string message;  // one line: the summary, or what is wrong (naming the file)
};
// Checks the text of a record file named `file` (for the messages): well-formed
// JSON, the format and a known version, every required member, the seal.
Verification verify_record(const std::string& text, const std::string& file);

}  // namespace vkmech::sentinel
