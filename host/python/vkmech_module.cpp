// `import vkmech`: load a scene, render it, and read every output channel as
// a numpy array by name (docs/python.md). The module is a thin layer over the
// same code the CLI runs: a render from Python and `vkmech render` with the
// same settings give the same pixels and the same files.
#include "adaptive/adaptive.hpp"
#include "cli/commands.hpp"
#include "cli/provenance.hpp"
#include "io/exr.hpp"
#include "io/output_set.hpp"
#include "render/descriptor.hpp"
#include "render/features.hpp"
#include "render/render_outputs.hpp"
#include "render/session.hpp"
#include "render/taxonomy.hpp"
#include "scene/environment.hpp"
#include "scene/scene.hpp"
#include "vk/context.hpp"

#include <pybind11/functional.h>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

namespace py = pybind11;
using namespace vkmech;

namespace vkmech {
void bind_stats(py::module_& parent);  // stats_bindings.cpp: vkmech.stats
}

namespace {

// The Python exception for a scene vkmech cannot load; its message starts with file:line.
PyObject* g_scene_error = nullptr;

struct PyScene {
    std::string name, path;
    std::vector<std::string> defines;  // -D name=value
    bool substitute = false;
    Scene scene;
};

// A rendered (or read) frame: every channel in the EXR's order, the header,
// and what writing it again needs.
struct PyFrame {
    int width = 0, height = 0;
    std::vector<std::string> names;
    std::vector<std::vector<float>> data;  // one per name, row-major, top row first
    std::vector<float> rgb;                // interleaved R, G, B
    std::map<std::string, std::vector<std::string>> header;
    // Set for frames rendered here (write() needs them); empty for frames read from a file.
    std::string scene_name;
    std::optional<RenderInfo> info;
    std::optional<Frame> frame;
    std::optional<Descriptor> descriptor;
    std::optional<DescriptorSummary> summary;

    void set_channels(std::vector<ExrChannel> ch) {
        names.clear();
        data.clear();
        for (auto& c : ch) {
            names.push_back(c.name);
            data.push_back(std::move(c.data));
        }
        const size_t n = static_cast<size_t>(width) * height;
        rgb.assign(3 * n, 0.0f);
        for (int k = 0; k < 3; ++k) {
            const std::string want(1, "RGB"[k]);
            for (size_t c = 0; c < names.size(); ++c)
                if (names[c] == want)
                    for (size_t i = 0; i < n; ++i) rgb[3 * i + k] = data[c][i];
        }
    }
    size_t index(const std::string& name) const {
        for (size_t i = 0; i < names.size(); ++i)
            if (names[i] == name) return i;
        throw py::key_error("no channel '" + name + "' (Frame.channels lists them)");
    }
};

PyScene load(const std::string& path_or_name, const std::map<std::string, std::string>& defines, bool substitute,
             const std::string& environment, float environment_scale, bool environment_panel) {
    PyScene s;
    try {
        s.path = resolve_scene_path(path_or_name);
    } catch (const std::exception& e) {
        PyErr_SetString(PyExc_FileNotFoundError, e.what());
        throw py::error_already_set();
    }
    s.name = scene_stem(path_or_name);
    s.substitute = substitute;
    LoadOptions lo;
    lo.params = defines;
    lo.substitute_unsupported = substitute;
    lo.environment_file = environment;
    lo.environment_scale = environment_scale;
    lo.environment_panel = environment_panel;
    for (const auto& [k, v] : defines) s.defines.push_back(k + "=" + v);
    try {
        s.scene = load_scene(s.path, lo);
    } catch (const SceneError& e) {
        PyErr_SetString(g_scene_error, e.what());
        throw py::error_already_set();
    }
    return s;
}

py::dict scene_info(const PyScene& s) {
    py::dict d;
    const Scene& sc = s.scene;
    d["name"] = s.name;
    d["path"] = s.path;
    d["width"] = sc.camera.width;
    d["height"] = sc.camera.height;
    d["triangles"] = sc.triangle_count();
    d["emitters"] = sc.emitters.size();
    d["materials"] = sc.materials.size();
    d["meshes"] = sc.meshes.size();
    d["max_depth"] = sc.integrator.max_depth;
    d["rr_depth"] = sc.integrator.rr_depth;
    d["features"] = Features::from_scene(sc).describe();
    d["defines"] = s.defines;
    d["warnings"] = sc.warnings;
    d["substitutions"] = sc.substitutions;
    d["environment"] = describe(sc.environment);
    d["directional_lights"] = sc.directional_lights.size();
    return d;
}

// What one render call sets up: the scene at the asked film size, a device, the pipeline.
struct PyRender {
    Scene scene;
    std::shared_ptr<vkmech::vk::Context> ctx;
    Traversal trav = Traversal::Bvh;
    std::unique_ptr<RenderSession> session;
    Features features;
    std::optional<Renderer> renderer;
    std::string light_selection, end_vertex;
    std::vector<std::string> class_names;  // a user taxonomy's (docs/lpe.md); empty: the buckets
    std::string taxonomy_json;
    alloc::ClassTraits traits;  // the labels' heavy and constant classes (a taxonomy's declared ones)
    // lpe= (docs/lpe.md, "Query channels"): the queries, and the renderer of their pass over the same samples.
    std::optional<SceneTaxonomy> queries;
    std::optional<Renderer> query_renderer;
};

PyRender prepare(const PyScene& s, std::optional<uint32_t> res, const std::string& estimator,
                 const std::string& light_selection, const std::string& end_vertex, bool capture,
                 std::optional<uint32_t> device, const std::string& kernel, const std::string& taxonomy = "",
                 const std::vector<std::string>& lpe_queries = {}) {
    PyRender r;
    r.scene = s.scene;
    std::optional<lpe::TaxonomySource> source;
    if (!taxonomy.empty()) {
        if (!capture) throw py::value_error("taxonomy needs capture=True (its classes are what the capture records)");
        try {
            source = lpe::read_taxonomy(taxonomy);
            give_named_shapes_own_materials(r.scene, *source);
        } catch (const lpe::LpeError& e) {
            throw py::value_error(std::string("taxonomy: ") + e.what());
        }
    }
    // After the taxonomy's, as the CLI does, so that the materials are numbered the same.
    std::optional<lpe::TaxonomySource> queries;
    if (!lpe_queries.empty()) {
        if (!capture)
            throw py::value_error("lpe needs capture=True (its channels are tallied as the capture's classes)");
        try {
            queries = lpe::taxonomy_from_lines(lpe_queries, "lpe");
            give_named_shapes_own_materials(r.scene, *queries);
        } catch (const lpe::LpeError& e) {
            throw py::value_error(e.what());
        }
    }
    if (res) {
        if (*res < 4 || *res > 16384) throw py::value_error("res must be 4..16384");
        r.scene.camera.set_film_width(static_cast<int>(*res));
    }
    vkmech::vk::ContextOptions co;
    co.device_index = device;
    co.kernel = vkmech::vk::parse_kernel_class(kernel);
    r.ctx = std::make_shared<vkmech::vk::Context>(co);
    r.trav = resolve_traversal(*r.ctx, Traversal::Auto);
    r.session = std::make_unique<RenderSession>(*r.ctx, r.scene, r.trav, parse_light_selection(light_selection));
    r.features = r.session->features(parse_estimator(estimator), capture);
    r.features.end_vertex = parse_end_vertex(end_vertex);
    if (source) {
        try {
            const SceneTaxonomy t = compile_scene_taxonomy(*source, r.session->scene());
            for (const auto& w : t.compiled.warnings)
                if (PyErr_WarnEx(PyExc_UserWarning, w.str().c_str(), 1) != 0) throw py::error_already_set();
            r.features.taxonomy = t.words;
            r.class_names = t.class_names();
            r.taxonomy_json = taxonomy_json(t);
            r.traits = class_traits(&t);
        } catch (const lpe::LpeError& e) {
            throw py::value_error(std::string("taxonomy: ") + e.what());
        }
    }
    r.renderer.emplace(r.session->renderer(r.features));
    if (queries) {
        try {
            r.queries = compile_scene_queries(*queries, r.session->scene());
        } catch (const lpe::LpeError& e) {
            throw py::value_error(e.what());
        }
        for (const auto& w : r.queries->compiled.warnings)
            if (PyErr_WarnEx(PyExc_UserWarning, w.str().c_str(), 1) != 0) throw py::error_already_set();
        Features qf = r.features;
        qf.taxonomy = r.queries->words;
        r.query_renderer.emplace(r.session->renderer(qf));
    }
    r.light_selection = light_selection;
    r.end_vertex = end_vertex;
    return r;
}

using ProgressFn = std::optional<std::function<void(uint32_t, uint32_t)>>;

// Between batches of a render that runs with the GIL released: Ctrl-C (KeyboardInterrupt),
// then the progress callback, if any.
std::function<void(uint32_t, uint32_t)> between_batches(const ProgressFn& progress) {
    return [&progress](uint32_t done, uint32_t total) {
        py::gil_scoped_acquire gil;
        if (PyErr_CheckSignals() != 0) throw py::error_already_set();
        if (progress) (*progress)(done, total);
    };
}

Frame render_spec(Renderer& renderer, RenderSpec spec, const ProgressFn& progress) {
    spec.progress = between_batches(progress);
    py::gil_scoped_release nogil;
    return renderer.render(spec);
}

// The frame of a render: its channels, header and what writing it needs. `spp`: the samples
// per pixel recorded (the mean under an adaptive plan), `sample_range` the provenance's.
// `queries`: a frame of the same samples tallied by r.queries' combinations (lpe=), or null.
PyFrame make_frame(const PyScene& s, const PyRender& r, Frame frame, uint32_t spp, uint32_t seed,
                   const std::string& sample_range, const std::string& features_note, const Frame* queries = nullptr) {
    const bool capture = r.features.capture;
    PyFrame out;
    out.width = frame.width;
    out.height = frame.height;
    out.scene_name = s.name;
    RenderInfo info{s.name,
                    s.path,
                    r.ctx->info().name,
                    to_string(r.trav),
                    to_string(r.features.estimator),
                    r.features.describe() + features_note,
                    spp,
                    seed,
                    capture};
    info.light_selection = r.light_selection;
    info.end_vertex = r.end_vertex;
    info.warnings = r.scene.warnings;
    info.substitutions = r.scene.substitutions;
    info.lights_at_infinity = describe_lights_at_infinity(r.scene);
    info.kernel = vkmech::vk::to_string(r.ctx->kernel());
    info.provenance = make_provenance(s.path, r.scene, s.defines, *r.ctx, r.trav, spp);
    if (!sample_range.empty()) info.provenance.sample_range = sample_range;
    if (capture) {
        out.descriptor = derive_descriptor(frame);
        if (!r.class_names.empty()) use_taxonomy_classes(*out.descriptor, r.class_names);
        out.summary = summarize(frame, *out.descriptor);
    }
    info.taxonomy = r.taxonomy_json;
    std::vector<ExrChannel> channels = render_channels(frame, out.descriptor ? &*out.descriptor : nullptr);
    if (queries) {
        info.extra_channels = query_channels(*queries, *r.queries);
        info.extra_json.emplace_back("lpe", queries_json(*r.queries, queries->seconds));
        info.queries = queries_json(*r.queries);
        channels.insert(channels.end(), info.extra_channels.begin(), info.extra_channels.end());
    }
    out.set_channels(std::move(channels));
    out.header = render_attributes(info, info.warnings, "", out.descriptor ? &*out.descriptor : nullptr);
    out.info = std::move(info);
    out.frame = std::move(frame);
    return out;
}

uint32_t mean_spp(const std::vector<uint32_t>& n) {
    uint64_t total = 0;
    for (uint32_t v : n) total += v;
    return n.empty() ? 0u : static_cast<uint32_t>(total / n.size());
}

constexpr uint32_t kMaxSpp = 1u << 20;  // the CLI's --spp limit

// An (H, W) array of per-pixel sample counts: whole numbers in 0..kMaxSpp, not all 0.
std::vector<uint32_t> sample_counts_of(const py::array& a, int width, int height) {
    if (a.ndim() != 2 || a.shape(0) != height || a.shape(1) != width)
        throw py::value_error("sample_counts must be a (" + std::to_string(height) + ", " + std::to_string(width) +
                              ") array, one count per pixel of the film");
    const char kind = a.dtype().kind();
    if (kind != 'i' && kind != 'u' && kind != 'f')
        throw py::value_error("sample_counts must hold numbers (an integer or float array)");
    const auto d = py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(a);
    std::vector<uint32_t> n(static_cast<size_t>(d.size()));
    bool any = false;
    for (size_t i = 0; i < n.size(); ++i) {
        const double v = d.data()[i];
        if (!(v >= 0.0 && v <= kMaxSpp && v == std::floor(v)))
            throw py::value_error("sample_counts[" + std::to_string(i / width) + ", " + std::to_string(i % width) +
                                  "] = " + std::to_string(v) + ": a count must be a whole number in 0.." +
                                  std::to_string(kMaxSpp));
        n[i] = static_cast<uint32_t>(v);
        any = any || n[i] > 0;
    }
    if (!any) throw py::value_error("sample_counts are all 0: nothing to render");
    return n;
}

PyFrame render(const PyScene& s, uint32_t spp, uint32_t seed, std::optional<uint32_t> res, const std::string& estimator,
               const std::string& light_selection, const std::string& end_vertex, bool capture,
               std::optional<uint32_t> device, const std::string& kernel, uint32_t batch,
               const std::optional<py::array>& sample_counts, const ProgressFn& progress, const std::string& taxonomy,
               const std::vector<std::string>& lpe_queries) {
    if (spp == 0 || spp > kMaxSpp) throw py::value_error("spp must be 1.." + std::to_string(kMaxSpp));
    if (batch == 0 || batch > 4096) throw py::value_error("batch must be 1..4096");
    if (res && (*res < 4 || *res > 16384)) throw py::value_error("res must be 4..16384");
    if (!lpe_queries.empty() && sample_counts)
        throw py::value_error("lpe is for a render of a fixed budget, not with sample_counts");
    RenderSpec spec;
    spec.spp = spp;
    spec.seed = seed;
    spec.batch_spp = batch;
    std::string range;
    if (sample_counts) {
        // Adaptive rendering: pixel p takes exactly samples [0, n(p)) of the seed. Checked
        // before any device work, against the film the render will have.
        Camera cam = s.scene.camera;
        if (res) cam.set_film_width(static_cast<int>(*res));
        spec.sample_counts = sample_counts_of(*sample_counts, cam.width, cam.height);
        range = adaptive_sample_range(spec.sample_counts);
        spp = mean_spp(spec.sample_counts);
    }
    PyRender r =
        prepare(s, res, estimator, light_selection, end_vertex, capture, device, kernel, taxonomy, lpe_queries);
    Frame frame = render_spec(*r.renderer, spec, progress);
    std::optional<Frame> queries;  // the same samples again, by the queries' combinations
    if (r.query_renderer) queries = render_spec(*r.query_renderer, spec, progress);
    return make_frame(s, r, std::move(frame), spp, seed, range, sample_counts ? " adaptive=sample_counts" : "",
                      queries ? &*queries : nullptr);
}

// `vkmech render --adaptive`: a pilot of `pilot` samples, strategy's allocation of 1 + budget
// samples per pixel on average (at least `floor`), the final render of the pool seed.
PyFrame adaptive(const PyScene& s, const std::string& strategy_name, uint32_t pilot, uint32_t budget, uint32_t floor,
                 uint32_t pilot_draw, std::optional<uint32_t> res, const std::string& estimator,
                 const std::string& light_selection, const std::string& end_vertex, std::optional<uint32_t> device,
                 const std::string& kernel, uint32_t batch, const ProgressFn& progress, const std::string& taxonomy) {
    const alloc::Strategy strategy = alloc::parse_strategy(strategy_name);  // ValueError on an unknown name
    if (strategy == alloc::Strategy::Oracle || strategy == alloc::Strategy::LabelOracle)
        throw py::value_error(strategy_name + " needs a converged reference: a control of the allocation study");
    // The CLI's ranges (render --pilot, --budget, --floor, --pilot-draw, --batch).
    if (pilot < 2 || pilot > 4096) throw py::value_error("pilot must be 2..4096");
    if (budget > 255) throw py::value_error("budget must be 0..255");
    if (floor < 1 || floor > 256) throw py::value_error("floor must be 1..256");
    if (pilot_draw > 899) throw py::value_error("pilot_draw must be 0..899");
    if (batch == 0 || batch > 4096) throw py::value_error("batch must be 1..4096");
    if (floor > 1 + budget) throw py::value_error("floor exceeds the per-pixel average (1 + budget)");
    const bool robust = alloc::needs_mom(strategy);
    if (robust) (void)alloc::mom_block_size(static_cast<int>(pilot));  // ValueError where MoM is undefined
    PyRender r = prepare(s, res, estimator, light_selection, end_vertex, true, device, kernel, taxonomy);
    Pilot p;
    {
        const ProgressFn none;  // the pilot checks for Ctrl-C; progress() reports the final render
        const auto check = between_batches(none);
        py::gil_scoped_release nogil;
        p = render_pilot(*r.renderer, pilot, downstream_seeds::pilot(pilot_draw), robust, check);
    }
    const alloc::PilotDiagnosis diag = alloc::diagnose_pilot(p, r.traits);
    const AdaptivePlan plan = plan_from_pilot(strategy, p, diag, pilot, budget, floor, pilot_draw, r.traits);
    Frame frame = render_spec(*r.renderer, adaptive_render_spec(plan, batch), progress);
    return make_frame(s, r, std::move(frame), mean_spp(plan.n), downstream_seeds::kPool, adaptive_sample_range(plan.n),
                      std::string(" adaptive=") + alloc::to_string(strategy));
}

py::array channel_view(py::object self, const std::string& name) {
    PyFrame& f = self.cast<PyFrame&>();
    std::vector<float>& v = f.data[f.index(name)];
    // A view of the frame's memory: the array keeps the frame alive (its base).
    return py::array_t<float>({f.height, f.width}, {sizeof(float) * f.width, sizeof(float)}, v.data(), self);
}

py::array rgb_view(py::object self) {
    PyFrame& f = self.cast<PyFrame&>();
    return py::array_t<float>({f.height, f.width, 3}, {sizeof(float) * 3 * f.width, sizeof(float) * 3, sizeof(float)},
                              f.rgb.data(), self);
}

py::dict header_dict(const PyFrame& f) {
    py::dict d;
    for (const auto& [k, v] : f.header) {
        if (v.size() == 1)
            d[py::str(k)] = v[0];
        else
            d[py::str(k)] = v;
    }
    return d;
}

std::vector<std::string> frame_write(const PyFrame& f, const std::string& dir) {
    if (!f.info || !f.frame)
        throw std::invalid_argument("this frame was read from a file: only a frame rendered here can be written");
    require_writable_dir(dir, "dir");
    OutputSet set(dir, f.scene_name);
    WrittenFiles w = write_render_outputs(set, *f.info, *f.frame, f.descriptor ? &*f.descriptor : nullptr,
                                          f.summary ? &*f.summary : nullptr);
    set.commit();
    std::vector<std::string> files = {w.exr, w.png, w.json};
    if (!w.dominant_png.empty()) files.push_back(w.dominant_png);
    if (!w.purity_png.empty()) files.push_back(w.purity_png);
    return files;
}

PyFrame frame_read(const std::string& path) {
    ExrImage img = read_exr_channels(path);
    PyFrame f;
    f.width = img.width;
    f.height = img.height;
    std::vector<ExrChannel> ch;
    for (const auto& name : img.order) ch.push_back({name, std::move(img.channels.at(name)), false});
    f.set_channels(std::move(ch));
    f.header = std::move(img.attributes);
    return f;
}

}  // namespace

PYBIND11_MODULE(vkmech, m) {
    m.doc() = "vkmech: a Vulkan path tracer that labels every pixel's light by its transport mechanism";
    g_scene_error = PyErr_NewException("vkmech.SceneError", PyExc_ValueError, nullptr);
    m.attr("SceneError") = py::handle(g_scene_error);
    py::register_exception<vkmech::vk::VulkanError>(m, "VulkanError", PyExc_RuntimeError);
    m.attr("__version__") = build_version();

    py::class_<PyScene>(m, "Scene", "A scene loaded from Mitsuba XML or glTF (vkmech.load)")
        .def_readonly("name", &PyScene::name)
        .def_readonly("path", &PyScene::path)
        .def("info", &scene_info, "What `vkmech check` reports, as a dict");

    py::class_<PyFrame>(m, "Frame", "A rendered frame: every EXR channel as a float32 (H, W) numpy view")
        .def_readonly("width", &PyFrame::width)
        .def_readonly("height", &PyFrame::height)
        .def_property_readonly(
            "channels", [](const PyFrame& f) { return f.names; }, "Channel names, in the EXR's order")
        .def("__getitem__", &channel_view, py::arg("name"), "A channel as a float32 (H, W) view of the frame's memory")
        .def("__contains__",
             [](const PyFrame& f, const std::string& n) {
                 for (const auto& x : f.names)
                     if (x == n) return true;
                 return false;
             })
        .def_property_readonly("rgb", &rgb_view, "The image, float32 (H, W, 3), linear RGB")
        .def_property_readonly("header", &header_dict, "The EXR header's attributes (provenance included)")
        .def("write", &frame_write, py::arg("dir"),
             "Writes the CLI's output set (EXR, PNGs, JSON, manifest) into dir; returns the files");

    m.def("load", &load, py::arg("path_or_name"), py::arg("defines") = std::map<std::string, std::string>{},
          py::arg("substitute") = false, py::arg("environment") = "", py::arg("environment_scale") = 1.0f,
          py::arg("environment_panel") = false,
          "Loads a scene file or a project scene by name; raises vkmech.SceneError (file:line: reason). "
          "environment: a lat-long map (EXR, HDR) that lights the scene (as the CLI's --environment); "
          "environment_panel: the paper's overhead panel for the scene's envmap/constant emitter");
    m.def("render", &render, py::arg("scene"), py::kw_only(), py::arg("spp") = 64, py::arg("seed") = 0,
          py::arg("res") = py::none(), py::arg("estimator") = "mis", py::arg("light_selection") = "uniform",
          py::arg("end_vertex") = "last-nondelta", py::arg("capture") = true, py::arg("device") = py::none(),
          py::arg("kernel") = "auto", py::arg("batch") = 8, py::arg("sample_counts") = py::none(),
          py::arg("progress") = py::none(), py::arg("taxonomy") = "", py::arg("lpe") = std::vector<std::string>{},
          "Renders the scene; releases the GIL, calls progress(done, total) between batches, and raises "
          "KeyboardInterrupt at the next batch on Ctrl-C. sample_counts: an (H, W) array n(p); pixel p then "
          "takes exactly samples [0, n(p)) of the seed and spp is ignored. taxonomy: a file of `name = "
          "light path expression` lines (docs/lpe.md); the channels are then by its classes. lpe: a list of "
          "'name=EXPR' queries, as `vkmech render --lpe`: channels lpe.NAME.R/G/B, lpe._rest and lpe._overlap "
          "from a second pass over the same samples (progress is called for each pass)");
    m.def("adaptive", &adaptive, py::arg("scene"), py::arg("strategy") = "bucket-floor", py::kw_only(),
          py::arg("pilot") = 16, py::arg("budget") = 32, py::arg("floor") = 1, py::arg("pilot_draw") = 0,
          py::arg("res") = py::none(), py::arg("estimator") = "nee", py::arg("light_selection") = "uniform",
          py::arg("end_vertex") = "last-nondelta", py::arg("device") = py::none(), py::arg("kernel") = "auto",
          py::arg("batch") = 8, py::arg("progress") = py::none(), py::arg("taxonomy") = "",
          "`vkmech render --adaptive`: a pilot, the strategy's Neyman allocation of 1 + budget samples per pixel "
          "on average, and the final render; n(p) is the frame's 'spp' channel. taxonomy: a file of `name = "
          "expression` lines (docs/lpe.md); its classes label the pilot, and its `[heavy]`, `[constant]` and "
          "`[rare]` classes are what the floor, the guard and robust-adaptive read");
    m.def("read", &frame_read, py::arg("path"), "Reads a vkmech EXR back as a Frame");
    bind_stats(m);
}
