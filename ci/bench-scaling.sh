#!/usr/bin/env bash
# Scaling of a vkmech render (docs/performance.md): whole-process wall time,
# peak resident memory, render time and paths/s, scene load and BVH build
# time, against pixels, samples per pixel and triangle count. A benchmark,
# not a test: run it on a quiet machine.
#
#   bash ci/bench-scaling.sh [VKMECH] [OUT_DIR]
#
# Pixels: glass_caustic at 64..512 px, 16 spp. Samples: glass_caustic at
# 128 px, 16..1024 spp. Triangles: the camera inside a closed box holding one
# tessellated sphere (OBJ, written here) of 1e3..1e6 triangles (2e6 with
# VKMECH_BENCH_BIG=1), 128 px, 16 spp. Writes OUT_DIR/scaling.md and prints it.
set -euo pipefail
VK="${1:-build/vkmech}"
OUT="${2:-out/bench-scaling}"
ROOT="$(cd "$(dirname "$0")/.." && pwd)"
mkdir -p "$OUT"
WORK="$(mktemp -d)"
trap 'rm -rf "$WORK"' EXIT
PY=/usr/bin/python3

run() {  # run LABEL ARGS...: one render; appends a row
    local label="$1"
    shift
    local dir="$WORK/r"
    rm -rf "$dir"
    /usr/bin/time -f "%e %M" -o "$WORK/time" "$VK" render "$@" --out "$dir" > "$WORK/log" 2>&1 ||
        { echo "render failed: $*" >&2; tail -5 "$WORK/log" >&2; exit 1; }
    local json
    json="$(ls "$dir"/*.json | grep -v manifest | head -1)"
    "$PY" - "$label" "$json" "$WORK/time" >> "$OUT/scaling.md" <<'PYEOF'
import json, sys
label, path, tfile = sys.argv[1:4]
d = json.load(open(path))
wall, rss_kb = open(tfile).read().split()[-2:]
s = d.get("scene_setup", {})
print(f"| {label} | {d['width']}x{d['height']} | {d['spp']} | {s.get('triangles', '?')} | {float(wall):.2f} | "
      f"{int(rss_kb) / 1024:.0f} | {s.get('load_seconds', float('nan')):.2f} | "
      f"{s.get('build_and_upload_seconds', float('nan')):.2f} | {d['pipeline_creation_seconds']:.2f} | "
      f"{d['wall_seconds']:.2f} | {d['paths_per_second']:.3g} |")
PYEOF
}

header() {
    printf '\n### %s\n\n| run | film | spp | triangles | process wall s | peak RSS MiB | load s | BVH build + upload s | pipeline s | render s | paths/s |\n|---|---|---|---|---|---|---|---|---|---|---|\n' "$1" >> "$OUT/scaling.md"
}

{
    echo "# vkmech scaling"
    echo
    echo "$(date -u '+%Y-%m-%d %H:%M UTC'), $("$VK" devices 2>/dev/null | grep -m1 -E '^ *\[?[0-9]' || true)"
    echo "load average before: $(cut -d' ' -f1-3 /proc/loadavg); command: bash ci/bench-scaling.sh $*"
} > "$OUT/scaling.md"

# Warm the pipeline cache (Mesa's shader cache on lavapipe) so compilation is not in the first row.
"$VK" render --scene glass_caustic --res 16 --spp 1 --estimator mis --out "$WORK/warm" > /dev/null 2>&1

header "Pixels (glass_caustic, 16 spp, MIS)"
for r in 64 128 256 512; do run "res $r" --scene glass_caustic --res "$r" --spp 16 --estimator mis; done

header "Samples per pixel (glass_caustic, 128 px, MIS)"
for n in 16 64 256 1024; do run "spp $n" --scene glass_caustic --res 128 --spp "$n" --estimator mis; done

header "Triangles (a box with one tessellated sphere, 128 px, 16 spp, MIS)"
SIZES="1000 10000 100000 1000000"
[ "${VKMECH_BENCH_BIG:-0}" = 1 ] && SIZES="$SIZES 2000000"
for t in $SIZES; do
    "$PY" - "$t" "$WORK/sphere.obj" <<'PYEOF'
import math, sys
target, path = int(sys.argv[1]), sys.argv[2]
# A latitude-longitude sphere with about `target` triangles: 2 * nu * (nv - 1).
nv = max(3, int(math.sqrt(target / 4)) + 1)
nu = max(3, round(target / (2 * (nv - 1))))
with open(path, "w") as f:
    w = f.write
    for j in range(nv + 1):
        th = math.pi * j / nv
        for i in range(nu):
            ph = 2 * math.pi * i / nu
            w(f"v {0.5 * math.sin(th) * math.cos(ph):.6f} {0.5 * math.sin(th) * math.sin(ph):.6f} {0.5 + 0.5 * math.cos(th):.6f}\n")
    for j in range(nv):
        for i in range(nu):
            a, b = j * nu + i + 1, j * nu + (i + 1) % nu + 1
            c, d = a + nu, b + nu
            if j > 0: w(f"f {a} {b} {d}\n")
            if j < nv - 1: w(f"f {a} {d} {c}\n")
PYEOF
    cat > "$WORK/mesh_box.xml" <<XML
<scene version="3.0.0">
  <integrator type="path"><integer name="max_depth" value="12"/></integrator>
  <sensor type="perspective"><float name="fov" value="70"/>
    <transform name="to_world"><lookat origin="0, -0.95, 1.3" target="0, 0.3, 0.45" up="0, 0, 1"/></transform>
    <film type="hdrfilm"><integer name="width" value="256"/><integer name="height" value="256"/></film></sensor>
  <bsdf type="twosided" id="white"><bsdf type="diffuse"><rgb name="reflectance" value="0.73, 0.73, 0.7"/></bsdf></bsdf>
  <bsdf type="twosided" id="metal"><bsdf type="roughconductor"><string name="material" value="Al"/>
    <float name="alpha" value="0.2"/></bsdf></bsdf>
  <shape type="cube"><transform name="to_world"><scale value="1, 1, 1"/><translate value="0, 0, 1"/></transform>
    <boolean name="flip_normals" value="true"/><ref id="white"/></shape>
  <shape type="obj"><string name="filename" value="sphere.obj"/>
    <transform name="to_world"><scale value="0.8"/><translate value="0, 0.3, 0.05"/></transform><ref id="metal"/></shape>
  <shape type="rectangle"><transform name="to_world"><scale value="0.25"/><rotate x="1" angle="180"/>
    <translate value="0, 0, 1.99"/></transform><emitter type="area"><rgb name="radiance" value="17, 12, 4"/></emitter></shape>
</scene>
XML
    run "$t tri" --scene "$WORK/mesh_box.xml" --res 128 --spp 16 --estimator mis
done
echo >> "$OUT/scaling.md"
echo "load average after: $(cut -d' ' -f1-3 /proc/loadavg)" >> "$OUT/scaling.md"
cat "$OUT/scaling.md"
