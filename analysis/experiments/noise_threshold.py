#!/usr/bin/python3
"""Noise threshold against uniform sampling, and the label-guarded rule against the plain
sample variance (render --noise-threshold; docs/descriptor.md §6.8, docs/results/noise_threshold.md).

For each scene, at one film width, against a reference (render --spp REF --seed 777, an
independent seed):
  at T        each rule as a user runs it, `--noise-threshold T --max-spp M` and no time limit:
              guarded (the default: bucket-floor's label floor and the guard) and plain
              (`--noise-rule observed-var`, the sample variance alone). Reported: seconds, samples,
              error, and the rule's broken promises: pixels it stopped as converged (err <= T) whose
              error against the reference is above 3 T.
  equal samples  every method takes the samples guarded took at T, B per pixel on average: both
              rules at T_eq < T with `--spp-budget B` (the budget stops them, and each rule's error
              map decides which pixels get the samples), and uniform `--spp B`. The seconds each
              took are reported beside: a sample costs the same whoever asks for it, so equal samples
              is equal time up to the rounds' overhead and the paths' own costs, which the seconds
              show. (Wall-clock limits were tried first: on a shared 2-core machine they did not
              reproduce, and uniform's calibrated spp missed the limit by up to 2x.)
Errors are of luminance, per pixel (x - ref)^2 / (ref^2 + 0.01 mean(ref)^2): their mean (relMSE,
the headline, unclamped) and their median (robust to fireflies). Every render runs the same binary,
estimator (mis) and seed 0; seconds are the renders' own (the JSON's), not process start-up.

Usage: noise_threshold.py --vkmech build/vkmech --out DIR [--scenes a,b,...|PATH.xml,...]
       [--res 128] [--ref-spp 2048] [--threshold 0.05] [--equal-time-threshold 0.02] [--max-spp 1024]
Writes DIR/results.json and DIR/noise_threshold.md (the tables).
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


def scene_args(scene, res):
    return ["--scene", scene, "--res", str(res), "--estimator", "mis"]


def summary(lum, ref):
    """relMSE (unclamped, the headline) and the median per-pixel relative squared error (firefly-robust)."""
    rel2 = (lum - ref) ** 2 / (ref ** 2 + 1e-2 * np.mean(ref) ** 2 + 1e-30)
    return {"relmse": float(np.mean(rel2)), "median_rel2": float(np.median(rel2))}


def one_scene(o, scene):
    name = os.path.splitext(os.path.basename(scene))[0] if scene.endswith(".xml") else scene
    d = os.path.join(o.out, name)
    base = scene_args(scene, o.res)
    run(o.vkmech, base + ["--spp", str(o.ref_spp), "--seed", "777", "--batch", "32"], os.path.join(d, "ref"))
    _, ref, _ = load(os.path.join(d, "ref"), name)
    row = {"scene": name, "pixels": int(ref.size)}

    # At T: each rule as a user runs it.
    at = {}
    for rule in ("guarded", "observed-var"):
        out = os.path.join(d, "t_" + rule)
        run(o.vkmech, base + ["--noise-threshold", str(o.threshold), "--max-spp", str(o.max_spp), "--noise-rule",
                              rule], out)
        img, lum, meta = load(out, name)
        nt = meta["noise_threshold"]
        true_rel = np.abs(lum - ref) / (ref + 0.01 * np.mean(ref) + 1e-30)
        stopped = img["err"] <= o.threshold
        miss = stopped & (true_rel > 3 * o.threshold)
        at[rule] = dict(summary(lum, ref), seconds=nt["seconds"], spp=nt["samples"] / ref.size,
                        converged=nt["converged_pixels"], at_max=nt["at_max_spp_pixels"], misses=int(miss.sum()),
                        miss_share=float(miss.sum() / max(1, stopped.sum())))
    row["at_threshold"] = at

    # Equal samples: every method takes the samples guarded took at T (B per pixel on average): both
    # rules at T_eq < T with --spp-budget B (the budget stops them, and each rule's error map decides
    # which pixels get the samples), uniform at --spp B. Seconds are measured and reported beside.
    budget = at["guarded"]["spp"]
    eq = {}
    for rule in ("guarded", "observed-var"):
        out = os.path.join(d, "eq_" + rule)
        run(o.vkmech, base + ["--noise-threshold", str(o.equal_time_threshold), "--spp-budget", "%.4f" % budget,
                              "--max-spp", str(o.max_spp), "--noise-rule", rule], out)
        _, lum, meta = load(out, name)
        nt = meta["noise_threshold"]
        eq[rule] = dict(summary(lum, ref), seconds=nt["seconds"], spp=nt["samples"] / ref.size,
                        rounds=len(nt["rounds"]))
    spp = max(1, int(round(budget)))
    out = os.path.join(d, "eq_uniform")
    run(o.vkmech, base + ["--spp", str(spp)], out)
    _, lum, meta = load(out, name)
    eq["uniform"] = dict(summary(lum, ref), seconds=meta["wall_seconds"], spp=spp, rounds=1)
    row["equal_time"] = eq
    row["budget_spp"] = budget
    return row


def table(rows, o):
    f = lambda x: "%.3g" % x  # noqa: E731
    lines = ["At T = %g (`--max-spp %d`, no time limit; reference %d spp): seconds, samples per pixel, relMSE, "
             "median relative squared error, and the pixels stopped as converged whose error against the reference "
             "exceeds 3 T (share of the stopped pixels)." % (o.threshold, o.max_spp, o.ref_spp), "",
             "| scene | plain: s, spp | plain: relMSE, median | plain: misses | guarded: s, spp | "
             "guarded: relMSE, median | guarded: misses |",
             "|---|---:|---:|---:|---:|---:|---:|"]
    for r in rows:
        a = r["at_threshold"]
        cells = []
        for k in ("observed-var", "guarded"):
            cells += ["%.1f, %.0f" % (a[k]["seconds"], a[k]["spp"]),
                      "%s, %s" % (f(a[k]["relmse"]), f(a[k]["median_rel2"])),
                      "%d (%.2f %%)" % (a[k]["misses"], 100 * a[k]["miss_share"])]
        lines.append("| %s | %s |" % (r["scene"], " | ".join(cells)))
    lines += ["", "Equal samples (the samples per pixel guarded took at T; the rules at `--noise-threshold %g "
              "--spp-budget` that, uniform at `--spp` that): relMSE and median relative squared error "
              "(lower is better), the measured seconds and samples per pixel; then the ratios of guarded's "
              "relMSE." % o.equal_time_threshold, "",
              "| scene | uniform | plain (observed-var) | guarded | guarded / uniform | guarded / plain |",
              "|---|---:|---:|---:|---:|---:|"]
    for r in rows:
        e = r["equal_time"]
        cell = lambda k: "%s, %s (%.1f s, %.0f spp)" % (  # noqa: E731
            f(e[k]["relmse"]), f(e[k]["median_rel2"]), e[k]["seconds"], e[k]["spp"])
        lines.append("| %s | %s | %s | %s | %.2f | %.2f |" % (
            r["scene"], cell("uniform"), cell("observed-var"), cell("guarded"),
            e["guarded"]["relmse"] / e["uniform"]["relmse"], e["guarded"]["relmse"] / e["observed-var"]["relmse"]))
    return "\n".join(lines) + "\n"


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--vkmech", default="build/vkmech")
    ap.add_argument("--out", required=True)
    ap.add_argument("--scenes", default=",".join(SEVEN))
    ap.add_argument("--res", type=int, default=128)
    ap.add_argument("--ref-spp", type=int, default=2048)
    ap.add_argument("--threshold", type=float, default=0.05)
    ap.add_argument("--equal-time-threshold", type=float, default=0.02)
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
