#!/usr/bin/env bash
# vkmech versus Blender Cycles on the CPU (docs/performance.md,
# "vkmech versus Blender Cycles (CPU)"). Renders the same 256x256 Cornell box
# with a glass sphere (scenes/glass_caustic.xml) in both, at the same samples
# per pixel and the same maximum path length, alternating the renderers run
# by run, times each whole process with /usr/bin/time and prints, per spp
# level, the median wall and CPU (user + system) times and the ratio
# vkmech / Cycles. A benchmark is a command, never a timed test.
#
#   ci/bench-cycles.sh [--spp 64,256] [--rounds 3] [--res 256]
#                      [--out out/bench-cycles] [--estimators mis[,nee,...]]
#                      [--capture on|off] [--scene FILE.xml] [--no-warmup]
#                      [--report-only]   (re-print the table from OUT's runs)
#   env: VKMECH (default build/vkmech), BLENDER (default blender)
#
# The Cycles scene is built from the same XML by
# analysis/validation/blender_scene.py (mapping and its checks:
# docs/validation.md). What is the same in both renders:
#   geometry (walls, block, light quad; the sphere is a 64 x 128 UV sphere
#   with interpolated normals in both), diffuse colours, glass IOR 1.5,
#   one-sided emitter of radiance (40, 35, 27) (Cycles mesh Emission of
#   strength 1 emits radiance = colour), camera, film, 1-pixel box filter,
#   spp, at most max_depth - 2 = 10 bounces of every kind (Mitsuba counts
#   segments incl. the one to the light), all cores, fixed seed, no
#   denoising, no adaptive sampling, no clamping, no Filter Glossy, caustics
#   on, light_sampling_threshold 0, no light tree (Cycles 3.4 has none), MIS
#   of light and BSDF sampling for the mesh light (vkmech --estimator mis),
#   Russian roulette from the same vertex (Cycles Min Light Bounces =
#   rr_depth - 2 = 3: Cycles skips it at bounce indices <= 3, i.e. the first
#   4 hits; vkmech from hit rr_depth = 5), EXR + PNG written.
# What differs (noise and work per path, not the expected image):
#   - the roulette rule: Cycles keeps a path with min(sqrt(max throughput), 1)
#     and decides before the hit's light sample; vkmech with
#     min(max throughput * eta^2, 0.95), after it;
#   - light sampling: Cycles samples the light triangle by solid angle where
#     it can and picks lights by power, vkmech by area, uniformly (one light
#     here, so the choice is the same);
#   - sample sequences: Cycles progressive multi-jitter, vkmech its own RNG;
#   - vkmech also labels every contribution (--capture on, its default and
#     its purpose) and writes the label outputs; --capture off drops that;
#   - start-up: vkmech creates Vulkan pipelines (kept in an on-disk pipeline
#     cache, warmed by one untimed run unless --no-warmup), Blender starts
#     Python and builds the scene in it.
set -euo pipefail
cd "$(dirname "$0")/.."

VKMECH=${VKMECH:-build/vkmech}
BLENDER=${BLENDER:-blender}
PY=/usr/bin/python3
LEVELS=64,256
ROUNDS=3
RES=256
OUT=out/bench-cycles
ESTIMATORS=mis
CAPTURE=on
SCENE=scenes/glass_caustic.xml
WARMUP=1
REPORT_ONLY=0

usage() { sed -n '2,14p' "$0" | sed 's/^# \{0,1\}//'; }
while [ $# -gt 0 ]; do
    case "$1" in
        --spp) LEVELS=$2; shift 2 ;;
        --rounds) ROUNDS=$2; shift 2 ;;
        --res) RES=$2; shift 2 ;;
        --out) OUT=$2; shift 2 ;;
        --estimators) ESTIMATORS=$2; shift 2 ;;
        --capture) CAPTURE=$2; shift 2 ;;
        --scene) SCENE=$2; shift 2 ;;
        --no-warmup) WARMUP=0; shift ;;
        --report-only) REPORT_ONLY=1; shift ;;
        -h|--help) usage; exit 0 ;;
        *) echo "bench-cycles.sh: unknown option $1" >&2; usage >&2; exit 2 ;;
    esac
done
for x in "$VKMECH" /usr/bin/time "$PY"; do
    [ -x "$x" ] || { echo "bench-cycles.sh: $x not found (set VKMECH / build first)" >&2; exit 2; }
done
command -v "$BLENDER" >/dev/null || { echo "bench-cycles.sh: $BLENDER not found (set BLENDER)" >&2; exit 2; }
[ -f "$SCENE" ] || { echo "bench-cycles.sh: no scene $SCENE" >&2; exit 2; }
case "$CAPTURE" in on|off) ;; *) echo "bench-cycles.sh: --capture on|off" >&2; exit 2 ;; esac
IFS=, read -r -a SPPS <<< "$LEVELS"
IFS=, read -r -a ESTS <<< "$ESTIMATORS"
RR=$(sed -n 's/.*name="rr_depth" value="\([0-9]*\)".*/\1/p' "$SCENE")
MINB=$(( ${RR:-5} > 2 ? ${RR:-5} - 2 : 0 ))
mkdir -p "$OUT"
OUT=$(cd "$OUT" && pwd)
CACHE="$OUT/pipeline-cache"

[ "$REPORT_ONLY" = 1 ] || {
    echo "date: $(date -u '+%Y-%m-%d %H:%M:%S UTC')"
    echo "host: $(nproc) cores, $(uname -m)"
    echo "uptime at start: $(uptime)"
    echo "blender: $("$BLENDER" --version 2>/dev/null | head -1)"
    echo "vkmech: $("$VKMECH" --version 2>/dev/null | head -1)"
    echo "mesa-vulkan-drivers: $(dpkg-query -W -f='${Version}' mesa-vulkan-drivers 2>/dev/null || echo unknown)"
    echo "scene: $SCENE, ${RES}x${RES}, spp ${LEVELS}, rounds ${ROUNDS}, vkmech estimators ${ESTIMATORS}, capture ${CAPTURE}, Cycles min light bounces ${MINB}"
} | tee "$OUT/env.txt"

# run NAME SPP ROUND: one timed whole process, outputs in $OUT/rROUND/sppSPP/NAME
run() {
    local name=$1 spp=$2 dir=$OUT/r$3/spp$2/$1
    rm -rf "$dir" && mkdir -p "$dir"
    if [ "$name" = cycles ]; then
        /usr/bin/time -f "%e %U %S" -o "$dir/time" \
            "$BLENDER" -b --factory-startup --python analysis/validation/blender_scene.py -- \
            "$SCENE" "$dir/image.exr" "$spp" "$RES" --threads 0 --seed 0 \
            --min-light-bounces "$MINB" --png "$dir/image.png" > "$dir/log" 2>&1
    else
        /usr/bin/time -f "%e %U %S" -o "$dir/time" \
            "$VKMECH" render --scene "$SCENE" --spp "$spp" --res "$RES" --estimator "${name#vkmech-}" \
            --capture "$CAPTURE" --seed 0 --pipeline-cache "$CACHE" --out "$dir" > "$dir/log" 2>&1
        local stem
        stem=$(basename "$SCENE" .xml)
        mv "$dir/$stem.exr" "$dir/image.exr" && mv "$dir/$stem.png" "$dir/image.png"
    fi || { echo "bench-cycles.sh: $name failed, see $dir/log" >&2; exit 1; }
    printf '  round %s  %-12s %5s spp  wall %7.2f s  cpu %7.2f s\n' "$3" "$name" "$spp" \
        $(awk '{print $1, $2 + $3}' "$dir/time")
}

NAMES=()
for e in "${ESTS[@]}"; do NAMES+=("vkmech-$e"); done
NAMES+=(cycles)
RUN_ROUNDS=$ROUNDS
if [ "$REPORT_ONLY" = 1 ]; then
    RUN_ROUNDS=0  # only the table below, from the runs already in $OUT
elif [ "$WARMUP" = 1 ]; then
    echo "warm-up (untimed: pipeline cache, file cache)"
    for n in "${NAMES[@]}"; do run "$n" 1 0 > /dev/null; done
fi
for ((r = 1; r <= RUN_ROUNDS; r++)); do
    for spp in "${SPPS[@]}"; do
        order=("${NAMES[@]}")
        if (( r % 2 == 0 )); then  # alternate who goes first, round by round
            order=(cycles "${NAMES[@]:0:${#NAMES[@]}-1}")
        fi
        for n in "${order[@]}"; do run "$n" "$spp" "$r"; done
    done
done

"$PY" - "$OUT" "$ROUNDS" "$LEVELS" "${NAMES[@]}" <<'EOF' | tee "$OUT/summary.md"
import os, statistics, sys
sys.path.insert(0, os.path.join(os.getcwd(), "analysis", "validation"))
from exr import read_exr

out, rounds, levels, names = sys.argv[1], int(sys.argv[2]), sys.argv[3].split(","), sys.argv[4:]
vk = [n for n in names if n != "cycles"]

def t(n, spp, r):
    w, u, s = map(float, open(os.path.join(out, "r%d" % r, "spp" + spp, n, "time")).read().split()[-3:])
    return w, u + s

print("| spp | renderer | median wall s | median CPU s | vkmech/Cycles wall | vkmech/Cycles CPU | mean luminance | vs Cycles |")
print("|---:|---|---:|---:|---:|---:|---:|---:|")
for spp in levels:
    med, lum = {}, {}
    for n in names:
        ts = [t(n, spp, r) for r in range(1, rounds + 1)]
        med[n] = (statistics.median(x[0] for x in ts), statistics.median(x[1] for x in ts))
        im = read_exr(os.path.join(out, "r%d" % rounds, "spp" + spp, n, "image.exr"))
        lum[n] = float((0.2126 * im["R"] + 0.7152 * im["G"] + 0.0722 * im["B"]).mean())
    for n in vk + ["cycles"]:
        c = med["cycles"]
        rw = "%.2f" % (med[n][0] / c[0]) if n != "cycles" else ""
        rc = "%.2f" % (med[n][1] / c[1]) if n != "cycles" else ""
        d = "%+.3f %%" % (100 * (lum[n] / lum["cycles"] - 1)) if n != "cycles" else ""
        print("| %s | %s | %.2f | %.2f | %s | %s | %.5f | %s |" % (spp, n, med[n][0], med[n][1], rw, rc, lum[n], d))
EOF
echo "per-run times: $OUT/r*/spp*/*/time (wall user sys); images: $OUT/r$ROUNDS/spp*/*/image.{exr,png}"
