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
    assert ["bucket." + b for b in BUCKETS] == names[3:10]
    assert "dominant" in frame and "lum_var" in frame and "spp" in frame
    files = frame.write(str(tmp_path))
    exr = [f for f in files if f.endswith(".exr")][0]
    assert vkmech.read(exr).channels == names


def test_a_channel_is_a_view_of_the_frame_not_a_copy(frame):
    a = frame["bucket.direct"]
    assert a.dtype == np.float32 and a.shape == (frame.height, frame.width)
    assert a.base is frame  # the array keeps the frame alive, and reads its memory
    assert np.shares_memory(a, frame["bucket.direct"])
    assert not a.flags.owndata
    rgb = frame.rgb
    assert rgb.shape == (frame.height, frame.width, 3)
    assert np.array_equal(rgb[:, :, 1], frame["G"])


def test_the_buckets_add_up_to_the_luminance(frame):
    total = sum(frame["bucket." + b].astype(np.float64) for b in BUCKETS)
    lum = frame["lum_mean"].astype(np.float64)
    assert lum.sum() > 0
    assert np.allclose(total, lum, rtol=1e-4, atol=1e-7)


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


def test_ctrl_c_raises_keyboard_interrupt_and_writes_nothing(tmp_path):
    code = ("import sys, vkmech\n"
            "s = vkmech.load('cubes_dof')\n"
            "print('rendering', flush=True)\n"
            "f = vkmech.render(s, spp=100000, res=64, batch=1)\n"
            "f.write(sys.argv[1])\n")
    out = tmp_path / "out"
    p = subprocess.Popen([sys.executable, "-c", code, str(out)], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                         env=dict(os.environ))
    assert p.stdout.readline().strip() == b"rendering"
    import signal
    import time
    time.sleep(1.0)
    p.send_signal(signal.SIGINT)
    _, err = p.communicate(timeout=60)
    assert p.returncode != 0
    assert b"KeyboardInterrupt" in err
    assert not out.exists() or not any(out.iterdir())
