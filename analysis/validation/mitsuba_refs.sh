#!/usr/bin/env bash
# Mitsuba's own reference images of its test scenes (mitsuba-data,
# tests/scenes/bsdf_spheres/refs/*_ref_rgb.exr) against vkmech: each scene is
# rendered as it is (with --substitute: the scenes' shared fragment has a point
# light) and once with the feature under test removed, so that the comparison
# says whether the feature moves vkmech's image towards Mitsuba's.
#
#   analysis/validation/mitsuba_refs.sh MITSUBA_DATA VKMECH [OUT]
#   env: SPP (1024), PY (/usr/bin/python3), CXX (g++)
#
# Scenes and what is removed: test_bumpmap_path.xml (the bump map: its nested
# diffuse alone), test_textured_roughconductor_path.xml (the alpha_u/alpha_v
# checkerboards: their mean, 0.175, as constants) and
# test_texturedprincipled1_path.xml (the metallic checkerboard: its mean, 0.4; then its
# anisotropic, clearcoat and sheen checkerboards: their means) and
# test_texturedprincipled2_path.xml (its anisotropic, spec_trans, clearcoat and sheen
# checkerboards: their means). Prints, per scene and
# variant, the image mean, the RMSE and relative L1 against the reference, and
# the correlation of (vkmech - without) with (reference - without).
# The references are PIZ-compressed, which exr.py does not read: a small
# OpenEXR program (Debian's libopenexr-dev, a build dependency) dumps them.
# docs/validation.md, "Mitsuba's reference images", records a run.
set -euo pipefail
[ $# -ge 2 ] || { sed -n 2,21p "$0"; exit 2; }
DATA=$(cd "$1" && pwd)
VKMECH=$(cd "$(dirname "$2")" && pwd)/$(basename "$2")
OUT=${3:-/tmp/mitsuba_refs}
SPP=${SPP:-1024}
PY=${PY:-/usr/bin/python3}
mkdir -p "$OUT"
OUT=$(cd "$OUT" && pwd)
SCENES=$DATA/tests/scenes/bsdf_spheres

cat >"$OUT/exr_rgb.cpp" <<'CPP'
// exr_rgb IN OUT: the RGB of any EXR OpenEXR reads, as int32 width, height, then float32 RGB rows.
#include <ImfArray.h>
#include <ImfRgbaFile.h>
#include <cstdio>
int main(int argc, char** argv) {
    if (argc != 3) return 2;
    Imf::RgbaInputFile f(argv[1]);
    Imath::Box2i dw = f.dataWindow();
    int w = dw.max.x - dw.min.x + 1, h = dw.max.y - dw.min.y + 1;
    Imf::Array2D<Imf::Rgba> px(h, w);
    f.setFrameBuffer(&px[0][0] - dw.min.x - dw.min.y * w, 1, w);
    f.readPixels(dw.min.y, dw.max.y);
    FILE* o = std::fopen(argv[2], "wb");
    if (!o) return 1;
    std::fwrite(&w, 4, 1, o);
    std::fwrite(&h, 4, 1, o);
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            float v[3] = {px[y][x].r, px[y][x].g, px[y][x].b};
            std::fwrite(v, 4, 3, o);
        }
    return std::fclose(o) == 0 ? 0 : 1;
}
CPP
# shellcheck disable=SC2046
${CXX:-g++} -O1 "$OUT/exr_rgb.cpp" -o "$OUT/exr_rgb" $(pkg-config --cflags --libs OpenEXR)

# render NAME XML: renders XML (run from its folder, as its relative paths need) into OUT/NAME.rgb.
render() {
    (cd "$SCENES" && "$VKMECH" --scene "$2" --substitute --spp "$SPP" --out "$OUT/$1" >"$OUT/$1.log" 2>&1) ||
        { echo "mitsuba_refs: $1 failed: $(tail -1 "$OUT/$1.log")"; exit 1; }
    "$OUT/exr_rgb" "$OUT/$1/$(basename "$2" .xml).exr" "$OUT/$1.rgb"
}

# compare SCENE [LABEL]: the reference against vkmech and vkmech without the feature
# (OUT/LABEL.vkmech.rgb and OUT/LABEL.without.rgb; LABEL defaults to SCENE).
compare() {
    "$OUT/exr_rgb" "$SCENES/refs/${1}_ref_rgb.exr" "$OUT/$1.ref.rgb"
    "$PY" - "$OUT" "$1" "${2:-$1}" <<'PY'
import sys
import numpy as np
out, scene, label = sys.argv[1], sys.argv[2], sys.argv[3]
def load(p):
    a = np.fromfile(p, dtype=np.float32)
    w, h = a[:2].view(np.int32)
    return a[2:].reshape(h, w, 3).astype(np.float64)
ref = load(f"{out}/{scene}.ref.rgb")
full, without = (load(f"{out}/{label}.{k}.rgb") for k in ("vkmech", "without"))
print(f"{label}: reference mean RGB {np.round(ref.reshape(-1, 3).mean(0), 4)}")
for name, x in (("vkmech", full), ("vkmech without the feature", without)):
    d = x - ref
    print(f"  {name:28s} mean RGB {np.round(x.reshape(-1, 3).mean(0), 4)}  RMSE {np.sqrt((d ** 2).mean()):.4f}"
          f"  relative L1 {np.abs(d).sum() / np.abs(ref).sum():.4f}")
corr = np.corrcoef((ref - without).ravel(), (full - without).ravel())[0, 1]
print(f"  the feature's effect correlates {corr:.3f} with the reference's difference from 'without'")
PY
}

# The variants are written beside the originals (their relative paths), then removed.
trap 'rm -f "$SCENES"/zz_vkmech_*.xml' EXIT
sed 's#<bsdf type="bumpmap" id="object_bsdf">#<bsdf type="twosided" id="object_bsdf">#;
     /<float name="scale" value="0.02"\/>/d; /<texture name="floor_tiles_bumpmap"/,/<\/texture>/d' \
    "$SCENES/test_bumpmap_path.xml" >"$SCENES/zz_vkmech_nobump.xml"
sed 's#<texture name="alpha_u" type="checkerboard">#<float name="alpha_u" value="0.175"/><texture name="unused_u" type="checkerboard">#;
     s#<texture name="alpha_v" type="checkerboard">#<float name="alpha_v" value="0.175"/><texture name="unused_v" type="checkerboard">#' \
    "$SCENES/test_textured_roughconductor_path.xml" >"$SCENES/zz_vkmech_flatalpha.xml"
sed 's#<texture name="metallic" type="checkerboard">#<float name="metallic" value="0.4"/><texture name="unused_m" type="checkerboard">#' \
    "$SCENES/test_texturedprincipled1_path.xml" >"$SCENES/zz_vkmech_flatmetallic.xml"
# principled's other textured parameters (since 2026-11-29 read at each hit): their means
# (the checkerboards' colour averages) as constants, metallic still textured.
flatten() {  # flatten NAME=MEAN ...: sed expressions replacing each texture by its mean
    for nm in "$@"; do
        printf 's#<texture name="%s" type="checkerboard">#<float name="%s" value="%s"/><texture name="unused_%s" type="checkerboard">#;' \
            "${nm%=*}" "${nm%=*}" "${nm#*=}" "${nm%=*}"
    done
}
sed "$(flatten anisotropic=0.425 clearcoat=0.5 sheen=0.55)" \
    "$SCENES/test_texturedprincipled1_path.xml" >"$SCENES/zz_vkmech_flatparams1.xml"
sed "$(flatten anisotropic=0.45 spec_trans=0.4 clearcoat=0.45 sheen=0.55)" \
    "$SCENES/test_texturedprincipled2_path.xml" >"$SCENES/zz_vkmech_flatparams2.xml"

render bump test_bumpmap_path.xml
cp "$OUT/bump.rgb" "$OUT/test_bumpmap.vkmech.rgb"
render nobump zz_vkmech_nobump.xml
cp "$OUT/nobump.rgb" "$OUT/test_bumpmap.without.rgb"
compare test_bumpmap

render alpha test_textured_roughconductor_path.xml
cp "$OUT/alpha.rgb" "$OUT/test_textured_roughconductor.vkmech.rgb"
render flatalpha zz_vkmech_flatalpha.xml
cp "$OUT/flatalpha.rgb" "$OUT/test_textured_roughconductor.without.rgb"
compare test_textured_roughconductor

render metallic test_texturedprincipled1_path.xml
cp "$OUT/metallic.rgb" "$OUT/test_texturedprincipled1.vkmech.rgb"
render flatmetallic zz_vkmech_flatmetallic.xml
cp "$OUT/flatmetallic.rgb" "$OUT/test_texturedprincipled1.without.rgb"
compare test_texturedprincipled1

render flatparams1 zz_vkmech_flatparams1.xml
cp "$OUT/metallic.rgb" "$OUT/test_texturedprincipled1_params.vkmech.rgb"
cp "$OUT/flatparams1.rgb" "$OUT/test_texturedprincipled1_params.without.rgb"
compare test_texturedprincipled1 test_texturedprincipled1_params

render params2 test_texturedprincipled2_path.xml
cp "$OUT/params2.rgb" "$OUT/test_texturedprincipled2.vkmech.rgb"
render flatparams2 zz_vkmech_flatparams2.xml
cp "$OUT/flatparams2.rgb" "$OUT/test_texturedprincipled2.without.rgb"
compare test_texturedprincipled2
