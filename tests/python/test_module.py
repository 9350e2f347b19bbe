"""`import vkmech` (docs/python.md), run by ctest with PYTHONPATH=build/python
and VKMECH_CLI set to the built vkmech binary."""
import os
import subprocess
import sys
import tempfile

import numpy as np
import pytest

import vkmech

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
CLI = os.environ.get("VKMECH_CLI", os.path.join(ROOT, "build", "vkmech"))
BUCKETS = ["emitter_direct", "direct", "diffuse_indirect", "glossy", "delta_mediated", "specular_direct", "other"]


@pytest.fixture(scope="module")
def frame():
    return vkmech.render(vkmech.load("cubes_dof"), spp=4, res=24, seed=3)


def test_channels_are_named_in_the_exr_order(frame, tmp_path):
    names = frame.channels
    assert names[:3] == ["R", "G", "B"]
    assert ["bucket.%s.%s" % (b, c) for b in BUCKETS for c in "RGB"] == names[3:24]
    assert ["lum." + b for b in BUCKETS] == names[24:31]
    assert "dominant" in frame and "lum_var" in frame and "spp" in frame
    files = frame.write(str(tmp_path))
    exr = [f for f in files if f.endswith(".exr")][0]
    assert vkmech.read(exr).channels == names


def test_a_channel_is_a_view_of_the_frame_not_a_copy(frame):
    a = frame["bucket.glossy.R"]
    assert a.dtype == np.float32 and a.shape == (frame.height, frame.width)
    assert a.base is frame  # the array keeps the frame alive, and reads its memory
    assert np.shares_memory(a, frame["bucket.glossy.R"])
    assert not a.flags.owndata
    rgb = frame.rgb
    assert rgb.shape == (frame.height, frame.width, 3)
    assert np.array_equal(rgb[:, :, 1], frame["G"])


def test_the_buckets_add_up_to_the_luminance(frame):
    total = sum(frame["lum." + b].astype(np.float64) for b in BUCKETS)
    lum = frame["lum_mean"].astype(np.float64)
    assert lum.sum() > 0
    assert np.allclose(total, lum, rtol=1e-4, atol=1e-7)


@pytest.mark.parametrize("name", ["ring_caustic", "kitchen_counter"])
def test_the_buckets_rgb_add_up_to_the_image(name):
    # Scenes where light arrives by several mechanisms, in colour: the seven buckets' R, G, B
    # add up to the image's, relative 1e-5 over the image.
    f = vkmech.render(vkmech.load(name), spp=8, res=32, seed=1)
    used = 0
    for c in "RGB":
        parts = [f["bucket.%s.%s" % (b, c)].astype(np.float64) for b in BUCKETS]
        assert all((p >= 0).all() for p in parts)
        used = max(used, sum(1 for p in parts if p.sum() > 0))
        image = f[c].astype(np.float64)
        assert image.sum() > 0
        assert np.abs(sum(parts) - image).sum() <= 1e-5 * image.sum(), c
    assert used >= 2


def test_a_1024_frame_reaches_numpy_without_a_copy():
    # Every channel of a 1024^2 frame as numpy arrays: the arrays view the frame (base), and
    # the process's resident memory grows by far less than one channel's 4 MiB each.
    def rss_mib():
        with open("/proc/self/statm") as f:
            return int(f.read().split()[1]) * os.sysconf("SC_PAGE_SIZE") / 2**20
    f = vkmech.render(vkmech.load("cubes_dof"), spp=1, res=1024, seed=0)
    before = rss_mib()
    arrays = [f[name] for name in f.channels]
    grown = rss_mib() - before
    assert all(a.base is f and a.shape == (1024, 1024) for a in arrays)
    data_mib = len(arrays) * 4.0
    assert data_mib > 100
    assert grown < 0.1 * data_mib, (grown, data_mib)


def test_python_and_cli_renders_give_the_same_pixels(frame, tmp_path):
    out = tmp_path / "cli"
    subprocess.run([CLI, "render", "--scene", "cubes_dof", "--spp", "4", "--res", "24", "--seed", "3", "--out",
                    str(out)], check=True, capture_output=True)
    cli = vkmech.read(str(out / "cubes_dof.exr"))
    assert cli.channels == frame.channels
    for name in frame.channels:
        assert np.array_equal(cli[name], frame[name]), name


def test_read_write_round_trips_every_channel_and_the_header(frame, tmp_path):
    files = frame.write(str(tmp_path))
    back = vkmech.read([f for f in files if f.endswith(".exr")][0])
    for name in frame.channels:
        assert np.array_equal(back[name], frame[name]), name
    header = back.header
    for key, value in frame.header.items():
        assert header[key] == value, key
    assert header["vkmech.runId"]  # written by the output set
    assert header["vkmech.sceneSha256"] == frame.header["vkmech.sceneSha256"]
    assert len(header["capDate"]) == 19


def test_provenance_and_scene_info():
    scene = vkmech.load("sweep_roughness", defines={"alpha": "0.1"})
    info = scene.info()
    assert info["triangles"] > 0 and info["emitters"] >= 1
    assert info["defines"] == ["alpha=0.1"]
    f = vkmech.render(scene, spp=2, res=16)
    assert f.header["vkmech.defines"] == "alpha=0.1"
    assert f.header["vkmech.sampleRange"] == "0:2"
    assert vkmech.__version__.startswith("0.")


def test_an_environment_map_lights_a_scene_and_is_recorded(tmp_path):
    # A 4 x 2 Radiance HDR of radiance 0.5 everywhere (RGBE 128 128 128 128: 128 x 2^(128 - 136)).
    sky = tmp_path / "sky.hdr"
    sky.write_bytes(b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 2 +X 4\n" + bytes([128, 128, 128, 128]) * 8)
    scene = vkmech.load("cubes_dof", environment=str(sky), environment_scale=2.0)
    info = scene.info()
    assert "sky.hdr" in info["environment"] and "scale 2" in info["environment"]
    assert info["directional_lights"] == 0
    f = vkmech.render(scene, spp=2, res=16)
    assert "sky.hdr" in f.header["vkmech.lightsAtInfinity"]
    assert "environment" in f.header["vkmech.features"]
    assert vkmech.load("cubes_dof").info()["environment"] == ""
    with pytest.raises(vkmech.SceneError):
        vkmech.load("cubes_dof", environment=str(tmp_path / "none.exr"))


def test_a_taxonomy_names_the_channels_and_matches_the_cli(tmp_path):
    # docs/lpe.md: per-light classes; the paper's taxonomy equals the built-in cascade.
    tax = tmp_path / "lights.lpe"
    tax.write_text("first = C .* <L.'sweep_light_0'>\nsecond = C .* <L.'sweep_light_1'>\n")
    scene = vkmech.load("sweep_lights", defines={"lights": "2"})
    f = vkmech.render(scene, spp=4, res=16, seed=2, taxonomy=str(tax))
    assert ["lum." + c for c in ("first", "second", "other")] == [n for n in f.channels if n.startswith("lum.")]
    total = sum(f["lum." + c].astype(np.float64) for c in ("first", "second", "other"))
    assert np.allclose(total, f["lum_mean"].astype(np.float64), rtol=1e-4, atol=1e-7)
    assert f["lum.first"].sum() > 0 and f["lum.second"].sum() > 0 and f["lum.other"].sum() == 0
    out = tmp_path / "cli"
    subprocess.run([CLI, "render", "--scene", "sweep_lights", "-D", "lights=2", "--spp", "4", "--res", "16", "--seed",
                    "2", "--taxonomy", str(tax), "--out", str(out)], check=True, capture_output=True)
    cli = vkmech.read(str(out / "sweep_lights.exr"))
    assert cli.channels == f.channels
    for name in f.channels:
        assert np.array_equal(cli[name], f[name]), name
    paper = vkmech.render(scene, spp=4, res=16, seed=2, taxonomy=os.path.join(ROOT, "taxonomies", "paper.lpe"))
    builtin = vkmech.render(scene, spp=4, res=16, seed=2)
    for b in BUCKETS:
        assert np.array_equal(paper["lum." + b], builtin["lum." + b]), b
    with pytest.raises(ValueError, match="lights.lpe"):
        (tmp_path / "lights.lpe").write_text("broken = C (D L\n")
        vkmech.render(scene, spp=1, res=8, taxonomy=str(tax))


def test_lpe_queries_add_overlapping_channels_as_the_cli_does(tmp_path):
    # docs/lpe.md "Query channels": `all` is the image, `first` and `bounced` overlap inside it.
    scene = vkmech.load("sweep_lights", defines={"lights": "2"})
    queries = ["all=C .* [LB]", "first=C .* <L.'sweep_light_0'>", "bounced=C . .+ [LB]"]
    f = vkmech.render(scene, spp=4, res=16, seed=2, lpe=queries)

    def rgb(prefix):
        return np.stack([f[prefix + c] for c in "RGB"]).astype(np.float64)

    image = np.stack([f[c] for c in "RGB"]).astype(np.float64)
    assert np.allclose(rgb("lpe.all."), image, rtol=1e-5, atol=1e-7)
    assert np.all(rgb("lpe._rest.") == 0)
    assert np.allclose(rgb("lpe._overlap."), rgb("lpe.first.") + rgb("lpe.bounced."), rtol=1e-5, atol=1e-7)
    assert rgb("lpe.first.").sum() > 0 and rgb("lpe.bounced.").sum() > 0
    assert rgb("lpe.first.").sum() < 0.9 * image.sum()
    args = [CLI, "render", "--scene", "sweep_lights", "-D", "lights=2", "--spp", "4", "--res", "16", "--seed", "2",
            "--out", str(tmp_path / "cli")]
    for q in queries:
        args += ["--lpe", q]
    subprocess.run(args, check=True, capture_output=True)
    cli = vkmech.read(str(tmp_path / "cli" / "sweep_lights.exr"))
    assert cli.channels == f.channels
    for name in f.channels:
        assert np.array_equal(cli[name], f[name]), name
    with pytest.raises(ValueError, match="lpe:1:"):
        vkmech.render(scene, spp=1, res=8, lpe=["x=C (D L"])
    with pytest.raises(ValueError, match="capture=True"):
        vkmech.render(scene, spp=1, res=8, capture=False, lpe=["x=C L"])
    with pytest.raises(ValueError, match="fixed budget"):
        vkmech.render(scene, res=8, lpe=["x=C L"], sample_counts=np.ones((8, 8)))


def test_progress_is_called_between_batches():
    calls = []
    vkmech.render(vkmech.load("cubes_dof"), spp=6, res=16, batch=2, progress=lambda d, t: calls.append((d, t)))
    assert calls == [(2, 6), (4, 6), (6, 6)]


def test_a_broken_scene_raises_with_file_and_line(tmp_path):
    bad = tmp_path / "bad.xml"
    bad.write_text('<scene version="3.0.0">\n  <shape type="sphere">\n    <float name="radius" value="x"/>\n'
                   '  </shape>\n</scene>\n')
    with pytest.raises(vkmech.SceneError) as e:
        vkmech.load(str(bad))
    assert str(bad) in str(e.value) and ":3" in str(e.value)
    with pytest.raises(FileNotFoundError):
        vkmech.load(str(tmp_path / "missing.xml"))


def test_bad_arguments_raise():
    scene = vkmech.load("cubes_dof")
    with pytest.raises(ValueError):
        vkmech.render(scene, spp=0)
    with pytest.raises(ValueError):
        vkmech.render(scene, spp=1, estimator="bogus")
    with pytest.raises(KeyError):
        vkmech.render(scene, spp=1, res=8)["no.such.channel"]
    with pytest.raises(RuntimeError):
        vkmech.read(str(ROOT) + "/README.md")


@pytest.mark.parametrize("call", ["vkmech.render(s, spp=100000, res=64, batch=1)",
                                  "vkmech.adaptive(s, 'bucket-floor', pilot=4096, res=128)"])  # Ctrl-C in the pilot (~13 s)
def test_ctrl_c_raises_keyboard_interrupt_and_writes_nothing(tmp_path, call):
    code = ("import sys, vkmech\n"
            "s = vkmech.load('cubes_dof')\n"
            "print('rendering', flush=True)\n"
            "f = " + call + "\n"
            "f.write(sys.argv[1])\n")
    out = tmp_path / "out"
    p = subprocess.Popen([sys.executable, "-c", code, str(out)], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                         env=dict(os.environ))
    assert p.stdout.readline().strip() == b"rendering"
    import signal
    import time
    time.sleep(1.0)
    p.send_signal(signal.SIGINT)
    sent = time.monotonic()
    _, err = p.communicate(timeout=60)
    # within a batch or two, not at the end of the render (either call takes tens of seconds)
    assert time.monotonic() - sent < 5.0
    assert p.returncode != 0
    assert b"KeyboardInterrupt" in err
    assert not out.exists() or not any(out.iterdir())


def test_adaptive_allocates_the_budget_and_matches_the_cli(tmp_path):
    scene = vkmech.load("kitchen_counter")
    f = vkmech.adaptive(scene, "bucket-floor", pilot=4, budget=4, res=24)
    n = f["spp"]
    assert n.sum() == 24 * 24 * (1 + 4)  # identical totals: 1 + budget per pixel on average
    assert n.min() >= 1 and n.max() > n.min()
    assert "adaptive=bucket-floor" in f.header["vkmech.features"]
    out = tmp_path / "cli"
    subprocess.run([CLI, "render", "--scene", "kitchen_counter", "--adaptive", "bucket-floor", "--pilot", "4",
                    "--budget", "4", "--res", "24", "--out", str(out)], check=True, capture_output=True)
    cli = vkmech.read(str(out / "kitchen_counter.exr"))
    for name in ("R", "G", "B", "spp", "lum_var", "dominant"):
        assert np.array_equal(cli[name], f[name]), name
    # The final render is the pool seed (1000, SPEC §4) at n(p) samples: the same pixels
    # again through render(sample_counts=...), a researcher's own allocation.
    again = vkmech.render(scene, seed=1000, res=24, estimator="nee", sample_counts=n.astype(np.uint32))
    assert np.array_equal(again["R"], f["R"]) and np.array_equal(again["spp"], n)
    for bad in (np.ones((3, 3), np.uint32), -n, n + 0.5, np.full(n.shape, 2**21), np.zeros(n.shape, np.int64)):
        with pytest.raises(ValueError):
            vkmech.render(scene, res=24, sample_counts=bad)
    with pytest.raises(ValueError):
        vkmech.adaptive(scene, "bucket-floor", pilot=1, res=24)
    with pytest.raises(ValueError):
        vkmech.adaptive(scene, "no-such-strategy", res=24)
    with pytest.raises(ValueError):
        vkmech.adaptive(scene, "oracle", res=24)
    # Under the paper's buckets written as a taxonomy ([heavy] and [constant] declared), the same
    # allocation and image, bit for bit.
    paper = os.path.join(ROOT, "taxonomies", "paper.lpe")
    t = vkmech.adaptive(scene, "guarded", pilot=4, budget=4, res=24, taxonomy=paper)
    g = vkmech.adaptive(scene, "guarded", pilot=4, budget=4, res=24)
    for name in ("R", "spp", "dominant", "lum.glossy"):
        assert np.array_equal(t[name], g[name]), name
    assert "vkmech.taxonomy" in t.header
    # The lines reversed: other slots, the same declared properties, the same allocation.
    rev = tmp_path / "reversed.lpe"
    rev.write_text("specular_direct [heavy rare] = C S+ [LB]\n"
                   "delta_mediated [heavy rare] = C (S+ [DG] | [DG]+ S) .* [LB]\n"
                   "glossy [heavy] = C [DG]+ G [LB]\ndiffuse_indirect = C [DG]+ D [LB]\ndirect = C [DG] [LB]\n"
                   "emitter_direct [constant] = C [LB]\n")
    r = vkmech.adaptive(scene, "guarded", pilot=4, budget=4, res=24, taxonomy=str(rev))
    assert np.array_equal(r["spp"], g["spp"]) and np.array_equal(r["R"], g["R"])
    # robust-adaptive reads the [rare] classes wherever they stand (reversed: other slots than the buckets').
    t = vkmech.adaptive(scene, "robust-adaptive", pilot=16, budget=4, res=24, taxonomy=str(rev))
    g = vkmech.adaptive(scene, "robust-adaptive", pilot=16, budget=4, res=24)
    assert np.array_equal(t["spp"], g["spp"]) and np.array_equal(t["R"], g["R"])


def test_label_agreement_on_hand_made_maps():
    a = np.array([0, 0, 1, 1, 255, 3], np.float32)
    b = np.array([0, 1, 1, 1, 0, 3], np.float32)
    r = vkmech.stats.label_agreement(a, b)
    assert r["pixels_compared"] == 5 and r["labelled_in_one_only"] == 1
    assert r["agreement"] == pytest.approx(4 / 5)
    # Cohen's kappa by hand: p_o = 0.8; marginals a (0: 2, 1: 2, 3: 1), b (0: 1, 1: 3, 3: 1)
    pe = (2 * 1 + 2 * 3 + 1 * 1) / 25
    assert r["kappa"] == pytest.approx((0.8 - pe) / (1 - pe))
    assert r["struct_share"] == 0.0  # the one swap (0 -> 1) stays within the light-tailed family
    same = vkmech.stats.label_agreement(a, a)
    assert same["agreement"] == 1.0 and same["max_drift"] == 0.0
    with pytest.raises(ValueError):
        vkmech.stats.label_agreement(np.array([7.0]), np.array([0.0]))


def test_spearman_split_half_and_neyman_on_known_inputs():
    assert vkmech.stats.spearman(np.array([1, 2, 3, 4.0]), np.array([1, 3, 2, 4.0])) == pytest.approx(0.8)
    ties = vkmech.stats.spearman(np.array([10, 20, 20, 30.0]), np.array([1, 2, 3, 4.0]))
    assert ties == pytest.approx(np.corrcoef([1, 2.5, 2.5, 4], [1, 2, 3, 4])[0, 1])
    x = np.array([[1, 2], [3, 4.0]])
    assert vkmech.stats.spearman(x, -x, mask=np.array([[1, 1], [0, 1]])) == pytest.approx(-1.0)

    rng = np.random.default_rng(5)
    spread = np.exp(np.linspace(-4, 4, 400)).reshape(20, 20)  # per-pixel noise levels far apart
    means = rng.normal(size=(10, 20, 20)) * spread
    rho, rhos = vkmech.stats.split_half(means)
    assert rhos.shape == (20,) and rho == pytest.approx(rhos.mean())
    assert rho > 0.6
    flat_rho, _ = vkmech.stats.split_half(rng.normal(size=(10, 20, 20)))
    assert abs(flat_rho) < 0.2  # one noise level everywhere: the halves' ranks are unrelated
    for seeds in (9, 0):
        with pytest.raises(ValueError):
            vkmech.stats.split_half(rng.normal(size=(seeds, 4, 4)))

    n = vkmech.stats.neyman_allocation(np.array([1, 4, 9, 16.0]), 20)
    # floor 1 each, 16 more shared 1:2:3:4 -> 2.6, 4.2, 5.8, 7.4, largest remainders first
    assert n.dtype == np.uint32 and list(n) == [3, 4, 6, 7]
    grid = vkmech.stats.neyman_allocation(np.ones((4, 8)), 4 * 8 * 3, floor=2)
    assert grid.shape == (4, 8) and (grid == 3).all()
    with pytest.raises(ValueError):
        vkmech.stats.neyman_allocation(np.ones(4), 2)
