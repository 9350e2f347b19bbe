#!/usr/bin/env bash
# Sensitivity checks: render deliberately wrong Cycles scenes and compare them
# with the vkmech renders from run_validation.sh (same OUT, SPP, RES), to show
# that the comparison detects the convention errors it is meant to rule out.
#   analysis/validation/sensitivity.sh   (after run_validation.sh)
#   env ONLY='env_*' runs only the mutants whose name matches the glob.
set -euo pipefail
cd "$(dirname "$0")/../.."
BLENDER=${BLENDER:-blender}
SPP=${SPP:-1024}
RES=${RES:-128}
OUT=${OUT:-out/validation}
ONLY=${ONLY:-*}
D=analysis/validation/scenes
run() {  # NAME SCENE ARGS...
    local name=$1 scene=$2; shift 2
    # shellcheck disable=SC2053
    [[ $name == $ONLY ]] || return 0
    local o="$OUT/mutant_$name"
    mkdir -p "$o/vkmech" "$o/cycles"
    cp "$OUT/vkmech/$scene.exr" "$OUT/vkmech/$scene.json" "$o/vkmech/"
    echo "== mutant $name: $scene, Cycles $*"
    "$BLENDER" -b --factory-startup --python analysis/validation/blender_scene.py -- \
        "$D/$scene.xml" "$o/cycles/$scene.exr" "$SPP" "$RES" "$@" > "$o/cycles/$scene.log" 2>&1
    /usr/bin/python3 analysis/validation/compare.py "$o" "$scene" | grep -E "^   [RGB] |region|block|sun in|per-instance"
}
run bounces11 val_diffuse --bounces 11          # max bounces = max_depth - 1 instead of - 2
run bounces9 val_diffuse --bounces 9            # max bounces = max_depth - 3
run two_sided_light val_diffuse --mutate two-sided-light
run roughness_linear val_metal --mutate roughness-linear   # Cycles roughness = alpha, not sqrt(alpha)
run env_no_rotation val_envmap --mutate env-no-rotation    # Mapping rotation left out (Cycles' own lat-long frame)
run env_mirror_u val_envmap --mutate env-mirror-u          # the map mirrored left-right (u -> -u)
run env_turn_180 val_envmap --mutate env-turn-180          # the map turned 180 deg about world z
run inst_order val_instances --mutate instance-order   # to_world(shape) @ to_world(instance): the composition reversed
run inst_no_shear val_instances --mutate no-shear     # matrix_world assigned as it is: Blender drops the sheared instances' shear
run blend_reversed val_blend --mutate blend-reversed   # blendbsdf's weight read as the first component's share
