#!/usr/bin/env bash
# Folder test: load every Mitsuba scene in a folder of third-party scenes with
# `vkmech check`, classify the outcome, retry the refused ones with
# --substitute, and render a sample of the loading scenes that have an
# environment (envmap/constant emitter) at a small size.
#
#   analysis/validation/folder_check.sh FOLDER VKMECH [OUT]
#   env: TIMEOUT (60 s per command), RES (64), SPP (4),
#        PER_KIND (5: renders per environment kind), RENDERS (/tmp/folder_renders),
#        PY (/usr/bin/python3)
#
# Scenes: every *.xml under FOLDER whose root element is <scene>, except
# include fragments (a file under a folder named include/ or fragments/, or
# the target of another file's <include filename=...>), which are counted
# apart. Outcome of `vkmech check --scene FILE` (run from FOLDER):
# exit 0 = loads, exit 2 = refused (grouped by its error), anything else
# (another code, a signal, a timeout = 124) = crash or hang, a bug.
# Writes OUT/results.tsv, OUT/logs/ and OUT/summary.md (also printed); exits 1
# when a command crashed or hung or a sample render failed or came out black.
# docs/scenes.md "Third-party scenes" records a run on the Mitsuba data folder.
set -euo pipefail
[ $# -ge 2 ] || { sed -n 2,20p "$0"; exit 2; }
HERE=$(cd "$(dirname "$0")" && pwd)
FOLDER=$(cd "$1" && pwd)
VKMECH=$(cd "$(dirname "$2")" && pwd)/$(basename "$2")
OUT=${3:-/tmp/folder_check}
mkdir -p "$OUT/logs"
OUT=$(cd "$OUT" && pwd)
export FOLDER VKMECH OUT HERE TIMEOUT=${TIMEOUT:-60} RES=${RES:-64} SPP=${SPP:-4} \
    PER_KIND=${PER_KIND:-5} RENDERS=${RENDERS:-/tmp/folder_renders}
cd "$FOLDER"
"${PY:-/usr/bin/python3}" - <<'EOF'
import collections, glob, os, re, subprocess, sys
import xml.etree.ElementTree as ET
E = os.environ
sys.path.insert(0, E["HERE"])
from exr import read_exr
import numpy as np

def run(args, log):
    cmd = ["timeout", "-k", "5", E["TIMEOUT"], E["VKMECH"]] + args
    r = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, errors="replace")
    open(os.path.join(E["OUT"], "logs", log), "w").write(r.stdout)
    return r.returncode, r.stdout

def reason(text):
    m = [l for l in text.splitlines() if l.startswith("vkmech: error:")]
    if not m: return ("no error line", "no error line")
    s = re.sub(r"^vkmech: error: (\S+?:\d+: )?", "", m[0])
    s = re.sub(r" \((looked for|expected|outside|docs/|participating|textures are|plugin names).*$", "", s)
    if s.startswith("unsupported <medium>"): cat = "participating medium"
    elif s.startswith("unsupported "): cat = "unsupported plugin"
    elif s.startswith("cannot open"): cat = "missing file"
    else: cat = "other"
    return cat, s

xmls, unparsable, roots = sorted(glob.glob("**/*.xml", recursive=True)), [], {}
for f in xmls:
    try: roots[f] = ET.parse(f).getroot()
    except ET.ParseError: unparsable.append(f)
# An <include> names a file relative to the including file or to the folder of
# a file that includes that one (Mitsuba resolves it against the main scene's).
bases = {f: {os.path.dirname(f)} for f in roots}
for _ in range(4):
    for f, root in roots.items():
        for inc in root.iter("include"):
            for b in list(bases[f]):
                t = os.path.normpath(os.path.join(b, inc.get("filename", "")))
                if t in bases: bases[t] |= bases[f]
targets = {os.path.normpath(os.path.join(b, inc.get("filename", "")))
           for f, root in roots.items() for inc in root.iter("include") for b in bases[f]} & set(roots)
scene_roots = [f for f, r in roots.items() if r.tag == "scene"]
frag = [f for f in scene_roots if f in targets or
        {"include", "fragments"} & set(os.path.dirname(f).split(os.sep))]
scenes = [f for f in scene_roots if f not in frag]

rows, loads_env = [], collections.defaultdict(list)
for f in scenes:
    log = f.replace(os.sep, "_")
    rc, text = run(["check", "--scene", f], log + ".check.txt")
    row = dict(file=f, rc=rc, cat="", reason="", sub_rc="", sub_reason="", env="")
    if rc == 0:
        m = re.search(r"^lights at infinity: *\n  environment: (\w+)", text, re.M)
        row["env"] = m.group(1) if m else ""
        if m: loads_env[m.group(1)].append(f)
    elif rc == 2:
        row["cat"], row["reason"] = reason(text)
        src, stext = run(["check", "--substitute", "--scene", f], log + ".substitute.txt")
        row["sub_rc"] = src
        if src == 2: row["sub_reason"] = reason(stext)[1]
    rows.append(row)

renders = []
for kind in sorted(loads_env):
    L = loads_env[kind]
    n = min(len(L), int(E["PER_KIND"]))
    for f in [L[i * len(L) // n] for i in range(n)]:
        name = os.path.splitext(f)[0].replace(os.sep, "_")
        out = os.path.join(E["RENDERS"], name)
        rc, _ = run(["render", "--scene", f, "--res", E["RES"], "--spp", E["SPP"], "--out", out], name + ".render.txt")
        exrs = glob.glob(os.path.join(out, "*.exr"))
        mean, finite = float("nan"), False
        if rc == 0 and len(exrs) == 1:
            R = read_exr(exrs[0])["R"]
            mean, finite = float(R.mean()), bool(np.isfinite(R).all())
        renders.append(dict(file=f, kind=kind, rc=rc, mean=mean, ok=rc == 0 and finite and mean > 0))

with open(os.path.join(E["OUT"], "results.tsv"), "w") as t:
    t.write("file\tcheck_rc\tcategory\treason\tsubstitute_rc\tsubstitute_reason\tenvironment\n")
    for r in rows:
        t.write("\t".join(str(r[k]) for k in ("file", "rc", "cat", "reason", "sub_rc", "sub_reason", "env")) + "\n")

ok = [r for r in rows if r["rc"] == 0]
ref = [r for r in rows if r["rc"] == 2]
bad = [r for r in rows if r["rc"] not in (0, 2)]
P = []
P.append(f"XML files: {len(xmls)} ({len(unparsable)} not parsable, "
         f"{len(roots) - len(scene_roots)} with another root element)")
P.append(f"root <scene>: {len(scene_roots)} = {len(scenes)} scenes + {len(frag)} include fragments "
         f"({len([f for f in frag if f in targets])} of them named by an <include>)")
P.append(f"scenes: {len(ok)} load, {len(ref)} refused (exit 2), {len(bad)} crash/hang")
P.append(f"refused, then with --substitute: {sum(r['sub_rc'] == 0 for r in ref)} load, "
         f"{sum(r['sub_rc'] == 2 for r in ref)} still refused, "
         f"{sum(r['sub_rc'] not in (0, 2) for r in ref)} crash/hang")
P.append("loading scenes with an environment: " +
         (", ".join(f"{k} {len(v)}" for k, v in sorted(loads_env.items())) or "none"))
P.append("\n| refusal (check) | category | scenes | load with --substitute |\n|---|---|---|---|")
g = collections.defaultdict(list)
for r in ref: g[(r["reason"], r["cat"])].append(r)
for (s, c), L in sorted(g.items(), key=lambda kv: (-len(kv[1]), kv[0])):
    P.append(f"| {s} | {c} | {len(L)} | {sum(r['sub_rc'] == 0 for r in L)} |")
g = collections.Counter(r["sub_reason"] for r in ref if r["sub_rc"] == 2)
P.append("\n| refusal with --substitute | scenes |\n|---|---|")
for s, n in sorted(g.items(), key=lambda kv: (-kv[1], kv[0])): P.append(f"| {s} | {n} |")
sbad = [r for r in ref if r["sub_rc"] not in (0, 2)]
P.append("\ncrash/hang:" + (" none" if not bad and not sbad else ""))
for r in bad:
    P.append(f"- exit {r['rc']}: (cd {E['FOLDER']} && timeout -k 5 {E['TIMEOUT']} {E['VKMECH']} check --scene {r['file']})")
for r in sbad:
    P.append(f"- exit {r['sub_rc']}: (cd {E['FOLDER']} && timeout -k 5 {E['TIMEOUT']} {E['VKMECH']} check --substitute --scene {r['file']})")
P.append(f"\n| rendered (--res {E['RES']} --spp {E['SPP']}) | environment | exit | mean R | ok |\n|---|---|---|---|---|")
for r in renders:
    P.append(f"| {r['file']} | {r['kind']} | {r['rc']} | {r['mean']:.4g} | {'yes' if r['ok'] else 'NO'} |")
open(os.path.join(E["OUT"], "summary.md"), "w").write("\n".join(P) + "\n")
print("\n".join(P))
sys.exit(1 if bad or sbad or not all(r["ok"] for r in renders) else 0)
EOF
