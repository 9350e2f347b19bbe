#!/usr/bin/python3
"""Noise threshold against uniform sampling, and the label-guarded rule against the plain
sample variance (render --noise-threshold; docs/descriptor.md §6.8, docs/results/noise_threshold.md).

For each scene, at one film width:
  reference   render --spp REF --seed 777 (an independent seed)
  uniform     render --spp N, N the most samples per pixel that fit in the time limit
              (the rate measured on a 16-spp render of the same scene)
  guarded     render --noise-threshold T --time-limit L (the label floor and the guard)
  plain       render --noise-threshold T --time-limit L --noise-rule observed-var
Two regimes:
  equal time  T small enough that only the time limit stops the rounds (--tight): every method
              gets the same seconds, and the error against the reference is compared;
  at T        T as a user sets it, no time limit: seconds used, and how often the rule's promise
              fails, i.e. the share of pixels it stopped as converged (err <= T) whose error
              against the reference is above 3 T (a 3-sigma miss for an honest estimate).
Every render runs the same binary, estimator (mis) and seed 0; seconds are the renders' own
(JSON: noise_threshold.seconds, or the frame time of a uniform render), not process start-up.

Usage: noise_threshold.py --vkmech build/vkmech --out DIR [--scenes a,b,...|PATH.xml,...]
       [--res 128] [--ref-spp 4096] [--threshold 0.05] [--tight 0.002] [--time-limit 4]
Writes DIR/results.json and DIR/noise_threshold.md (a table).
"""
import argparse
import json
import os
import subprocess
import sys
import time

import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "validation"))
from exr import read_exr  # noqa: E402

LUM = (0.2126, 0.7152, 0.0722)
# The seven first-party scenes of the studies (host/app/study/study_runner.cpp: first_party_scenes).
SEVEN = ["cubes_dof", "glass_caustic", "snooker", "tabletop_mixed", "tabletop_separated", "ring_caustic",
         "kitchen_counter"]


def run(vkmech, args, out):
    cmd = [vkmech, "render"] + args + ["--out", out]
    t = time.time()
    p = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    if p.returncode != 0:
        sys.exit("failed (%d): %s\n%s" % (p.returncode, " ".join(cmd), p.stdout[-3000:]))
    return time.time() - t


def load(out, name):
    img = read_exr(os.path.join(out, name + ".exr"))
    lum = LUM[0] * img["R"] + LUM[1] * img["G"] + LUM[2] * img["B"]
    with open(os.path.join(out, name + ".json")) as f:
        meta = json.load(f)
    return img, lum, meta


def rel_mse(lum, ref):
    return float(np.mean((lum - ref) ** 2 / (ref ** 2 + 1e-2 * np.mean(ref) ** 2 + 1e-30)))


def scene_args(scene, res):
    return ["--scene", scene, "--res", str(res), "--estimator", "mis"]


def one_scene(o, scene):
    name = os.path.splitext(os.path.basename(scene))[0] if scene.endswith(".xml") else scene
    d = os.path.join(o.out, name)
    base = scene_args(scene, o.res)
    run(o.vkmech, base + ["--spp", str(o.ref_spp), "--seed", "777", "--batch", "32"], os.path.join(d, "ref"))
    _, ref, _ = load(os.path.join(d, "ref"), name)
    run(o.vkmech, base + ["--spp", "16"], os.path.join(d, "rate"))
    _, _, m16 = load(os.path.join(d, "rate"), name)
    sec_per_spp = m16["wall_seconds"] / 16.0
    row = {"scene": name, "pixels": int(ref.size)}

    # Equal time.
    eq = {}
    for rule in ("guarded", "observed-var"):
        out = os.path.join(d, "eq_" + rule)
        run(o.vkmech, base + ["--noise-threshold", str(o.tight), "--time-limit", str(o.time_limit), "--max-spp",
                              "65536", "--noise-rule", rule], out)
        _, lum, meta = load(out, name)
        nt = meta["noise_threshold"]
        eq[rule] = {"seconds": nt["seconds"], "spp": nt["samples"] / ref.size, "relmse": rel_mse(lum, ref),
                    "rounds": len(nt["rounds"])}
    spp = max(1, int(eq["guarded"]["seconds"] / sec_per_spp)) if sec_per_spp else 16
    out = os.path.join(d, "eq_uniform")
    run(o.vkmech, base + ["--spp", str(spp)], out)
    _, lum, meta = load(out, name)
    eq["uniform"] = {"seconds": meta["wall_seconds"], "spp": spp, "relmse": rel_mse(lum, ref), "rounds": 1}
    row["equal_time"] = eq

    # At T.
    at = {}
    for rule in ("guarded", "observed-var"):
        out = os.path.join(d, "t_" + rule)
        run(o.vkmech, base + ["--noise-threshold", str(o.threshold), "--max-spp", str(o.max_spp), "--noise-rule",
                              rule], out)
        img, lum, meta = load(out, name)
        nt = meta["noise_threshold"]
        err = img["err"]
        true_rel = np.abs(lum - ref) / (ref + 0.01 * np.mean(ref) + 1e-30)
        stopped = err <= o.threshold
        miss = stopped & (true_rel > 3 * o.threshold)
        at[rule] = {"seconds": nt["seconds"], "spp": nt["samples"] / ref.size, "relmse": rel_mse(lum, ref),
                    "converged": nt["converged_pixels"], "at_max": nt["at_max_spp_pixels"],
                    "misses": int(miss.sum()), "miss_share": float(miss.sum() / max(1, stopped.sum()))}
    row["at_threshold"] = at
    return row


def table(rows, o):
    lines = ["Equal time (`--noise-threshold %g --time-limit %g`; uniform at the spp that fits): relMSE of "
             "luminance against a %d-spp reference (lower is better), seconds, samples per pixel." %
             (o.tight, o.time_limit, o.ref_spp), "",
             "| scene | uniform | plain (observed-var) | guarded | guarded / uniform | guarded / plain |",
             "|---|---:|---:|---:|---:|---:|"]
    for r in rows:
        e = r["equal_time"]
        cell = lambda k: "%.4g (%.1f s, %.0f spp)" % (e[k]["relmse"], e[k]["seconds"], e[k]["spp"])  # noqa: E731
        lines.append("| %s | %s | %s | %s | %.2f | %.2f |" % (
            r["scene"], cell("uniform"), cell("observed-var"), cell("guarded"),
            e["guarded"]["relmse"] / e["uniform"]["relmse"], e["guarded"]["relmse"] / e["observed-var"]["relmse"]))
    lines += ["", "At T = %g (`--max-spp %d`, no time limit): seconds, samples per pixel, relMSE, and the "
              "pixels the rule stopped as converged whose error against the reference exceeds 3 T." %
              (o.threshold, o.max_spp), "",
              "| scene | plain: s, spp, relMSE | plain: misses | guarded: s, spp, relMSE | guarded: misses |",
              "|---|---:|---:|---:|---:|"]
    for r in rows:
        a = r["at_threshold"]
        cell = lambda k: "%.1f, %.0f, %.4g" % (a[k]["seconds"], a[k]["spp"], a[k]["relmse"])  # noqa: E731
        miss = lambda k: "%d (%.2f %%)" % (a[k]["misses"], 100 * a[k]["miss_share"])  # noqa: E731
        lines.append("| %s | %s | %s | %s | %s |" % (r["scene"], cell("observed-var"), miss("observed-var"),
                                                     cell("guarded"), miss("guarded")))
    return "\n".join(lines) + "\n"


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--vkmech", default="build/vkmech")
    ap.add_argument("--out", required=True)
    ap.add_argument("--scenes", default=",".join(SEVEN))
    ap.add_argument("--res", type=int, default=128)
    ap.add_argument("--ref-spp", type=int, default=4096)
    ap.add_argument("--threshold", type=float, default=0.05)
    ap.add_argument("--tight", type=float, default=0.002)
    ap.add_argument("--time-limit", type=float, default=4.0)
    ap.add_argument("--max-spp", type=int, default=1024)
    o = ap.parse_args()
    rows = []
    for s in o.scenes.split(","):
        print("noise_threshold.py: " + s, file=sys.stderr, flush=True)
        rows.append(one_scene(o, s))
        with open(os.path.join(o.out, "results.json"), "w") as f:
            json.dump({"settings": vars(o), "rows": rows}, f, indent=1)
    md = table(rows, o)
    with open(os.path.join(o.out, "noise_threshold.md"), "w") as f:
        f.write(md)
    print(md)


if __name__ == "__main__":
    main()
