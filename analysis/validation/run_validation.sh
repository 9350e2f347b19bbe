#!/usr/bin/env bash
# Render the validation scenes with vkmech (--estimator mis) and Blender
# Cycles, one render at a time, then compare channel means.
#
#   analysis/validation/run_validation.sh [SCENE ...]
#   env: VKMECH (default build/vkmech), BLENDER (default blender),
#        SPP (1024), RES (128), OUT (out/validation), THREADS (Cycles threads, 2)
#
# val_instances is an ordinary XML scene (a shapegroup and its instances;
# blender_scene.py instances a collection).
# val_gltf (not in the default list) is a glTF file lit only by --environment
# textures/sky.hdr: both renderers get the map on the command line.
set -euo pipefail
cd "$(dirname "$0")/../.."
VKMECH=${VKMECH:-build/vkmech}
BLENDER=${BLENDER:-blender}
SPP=${SPP:-1024}
RES=${RES:-128}
OUT=${OUT:-out/validation}
PY=/usr/bin/python3
SCENES=("$@")
[ ${#SCENES[@]} -gt 0 ] || SCENES=(val_diffuse val_glass val_metal val_texture val_envmap val_instances val_blend)
D=analysis/validation/scenes

$PY analysis/validation/make_scenes.py   # deterministic: rewrites the committed files identically
mkdir -p "$OUT/vkmech" "$OUT/cycles"
for s in "${SCENES[@]}"; do
    if [ "$s" = val_gltf ]; then
        file="$D/$s.gltf"
        env=(--environment "$D/textures/sky.hdr")
    else
        file="$D/$s.xml"
        env=()
    fi
    echo "== $s: vkmech"
    "$VKMECH" render --scene "$file" "${env[@]}" --spp "$SPP" --res "$RES" --estimator mis --out "$OUT/vkmech" \
        | grep -E "wall|paths|nonfinite|warning" || true
    echo "== $s: Cycles"
    t0=$(date +%s.%N)
    "$BLENDER" -b --factory-startup --python analysis/validation/blender_scene.py -- \
        "$file" "$OUT/cycles/$s.exr" "$SPP" "$RES" --threads "${THREADS:-2}" "${env[@]}" > "$OUT/cycles/$s.log" 2>&1
    t1=$(date +%s.%N)
    echo "$t0 $t1" | awk '{printf "%.1f\n", $2 - $1}' > "$OUT/cycles/$s.time"
    grep -E "blender_scene|Saved" "$OUT/cycles/$s.log"
done
$PY analysis/validation/compare.py "$OUT" "${SCENES[@]}"
