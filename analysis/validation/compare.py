"""Compare vkmech and Cycles renders of the validation scenes.

  /usr/bin/python3 analysis/validation/compare.py OUTDIR SCENE [SCENE ...]

reads OUTDIR/vkmech/SCENE.exr (+ .json for wall_seconds) and
OUTDIR/cycles/SCENE.exr (+ SCENE.time), prints per scene the channel means,
relative differences (Cycles as the reference), the vkmech standard error of
the mean (from its per-pixel lum_var channel), a left/right half check
(catches a mirrored camera) and the relative RMS difference of 16x16-pixel
block means; writes OUTDIR/SCENE_side_by_side.png (vkmech | Cycles) and
OUTDIR/results.md (the same table in Markdown)."""
import json
import os
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from exr import read_exr  # noqa: E402

TOL = 0.02
# Regions of interest (pixel circles in the 128x128 image, scaled with RES):
# the sphere's projection, centre (81.4, 93.9) px and radius 19.9 px from
# the camera (0,-3.9,1), fov_x 39.3 deg and sphere (0.35,-0.3,0.4), r 0.4;
# 17 px keeps the silhouette edge out.
# val_gltf: discs inside the sphere and the box, computed by gltf_rois.
# val_instances: the pixels of the floor instances and of the floating ones,
# computed by instance_masks from the geometry.
# val_envmap: the mirror sphere, centre (64.0, 62.4) px, radius 17.4 px, and
# the rough gold sphere, centre (108.1, 74.4) px, radius 13.4 px (from
# make_scenes.project and the camera distance); 14 and 11 px keep the edges out.
# The mirror sphere's region leaves out 3.5 px around the sun's reflection
# (58.5, 57.7): those few pixels of radiance ~400 would dominate its noise.
ROI = {"val_glass": [("sphere", 81.4, 93.9, 17.0)], "val_metal": [("sphere", 81.4, 93.9, 17.0)],
       "val_blend": [("sphere", 81.4, 93.9, 17.0)],
       "val_envmap": [("mirror sphere", 64.0, 62.4, 14.0, (58.5, 57.7, 3.5)), ("gold sphere", 108.1, 74.4, 11.0)]}


def sun_in_mirror(res):
    """Where the sun disc of val_envmap's sky appears in the mirror sphere,
    by tracing each pixel centre's camera ray (geometry from make_scenes.py):
    the luminance-weighted centroid of the pixels whose reflected ray falls
    inside the sun's disc, and their count."""
    import make_scenes as ms
    (o, t, fov) = ms.ENV_CAM
    (c, r) = ms.MIRROR_SPHERE
    o, t, c = np.array(o), np.array(t), np.array(c)
    f = (t - o) / np.linalg.norm(t - o)
    right = np.cross(f, [0, 0, 1.0])
    right /= np.linalg.norm(right)
    up = np.cross(right, f)
    k = np.tan(np.radians(fov) / 2)
    sun = np.array(ms.SUN_DIR) / np.linalg.norm(ms.SUN_DIR)
    cosr = np.cos(np.radians(ms.SUN_RADIUS_DEG))
    n_sub = 8  # 8 x 8 rays per pixel
    hits = np.zeros((res, res))
    s = (np.arange(n_sub) + 0.5) / n_sub
    for y in range(res):
        for x in range(res):
            sx, sy = np.meshgrid(x + s, y + s)
            d = f + right[None, None] * (k * (2 * sx / res - 1))[..., None] + up * (k * (1 - 2 * sy / res))[..., None]
            d /= np.linalg.norm(d, axis=-1, keepdims=True)
            oc = o - c
            b = d @ oc
            disc = b * b - (oc @ oc - r * r)
            ok = disc > 0
            tt = -b - np.sqrt(np.where(ok, disc, 0))
            p = o + tt[..., None] * d
            n = (p - c) / r
            refl = d - 2 * np.sum(d * n, -1, keepdims=True) * n
            hits[y, x] = np.mean(ok & (refl @ sun > cosr))
    yy, xx = np.mgrid[0:res, 0:res] + 0.5
    w = hits.sum()
    return (float((xx * hits).sum() / w), float((yy * hits).sum() / w), w)


def gltf_camera(res):
    """val_gltf's camera (make_scenes.GLTF_CAM; glTF frame, +y up, yfov, aspect 1):
    origin, forward, right, up and tan(fov / 2)."""
    import make_scenes as ms
    (o, t, fov) = ms.GLTF_CAM
    o, t = np.array(o, float), np.array(t, float)
    f = (t - o) / np.linalg.norm(t - o)
    right = np.cross(f, [0, 1.0, 0])
    right /= np.linalg.norm(right)
    return o, f, right, np.cross(right, f), np.tan(np.radians(fov) / 2)


def gltf_sky_rows(res):
    """Image rows of val_gltf that see only the sky: every object is below the
    camera (y 1.6; box top 1.0, sphere top 1.2), so a pixel whose lowest ray
    (its bottom edge) points upwards sees the environment map alone."""
    o, f, right, up, k = gltf_camera(res)
    return [y for y in range(res) if f[1] + up[1] * k * (1 - 2 * (y + 1) / res) > 0]


def gltf_rois(res):
    """Discs inside the projections of val_gltf's sphere and box (scaled to 128 px)."""
    import make_scenes as ms
    o, f, right, up, k = gltf_camera(res)
    def proj(p):
        q = np.array(p, float) - o
        z = q @ f
        return (64 * (1 + (q @ right) / z / k), 64 * (1 - (q @ up) / z / k), z)
    (c, r) = ms.GLTF_SPHERE
    sx, sy, sz = proj(c)
    (b, e, _) = ms.GLTF_BOX
    bx, by, bz = proj((b[0], b[1] + e / 2, b[2]))
    return [("sphere", sx, sy, 0.8 * 64 * r / sz / k), ("box", bx, by, 0.6 * 64 * (e / 2) / bz / k)]


def instance_boxes(res):
    """val_instances: each instance's pixel box (the projected corners of the
    group's box under its to_world, make_scenes.inst_world_boxes): every pixel
    the instance covers, and some floor or wall around it. Returns
    (y0, y1, x0, x1, floating) per instance."""
    import make_scenes as ms
    out = []
    for (lo, hi) in ms.inst_world_boxes():
        pts = [ms.project((x, y, z), *ms.BOX_CAM, res)
               for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])]
        x0, x1 = int(np.floor(min(p[0] for p in pts))), int(np.ceil(max(p[0] for p in pts)))
        y0, y1 = int(np.floor(min(p[1] for p in pts))), int(np.ceil(max(p[1] for p in pts)))
        out.append((max(y0, 0), y1, max(x0, 0), x1, lo[2] > 0.01))
    return out


def instance_masks(res):
    """val_instances: the union of the pixel boxes of the 25 instances on the
    floor, and of the 6 floating ones."""
    masks = {"floor instances": np.zeros((res, res), bool), "floating instances": np.zeros((res, res), bool)}
    for (y0, y1, x0, x1, floating) in instance_boxes(res):
        masks["floating instances" if floating else "floor instances"][y0:y1, x0:x1] = True
    return list(masks.items())


def env_regions(v):
    """A scene without regions of its own (a local glTF file under
    --environment), from vkmech's own render: the pixels where no sample
    scattered (vkmech's `depth` channel 0: only the map seen directly) and the
    geometry's pixels (depth > 0: some sample scattered), the latter eroded by
    one pixel to keep silhouettes out. Emission does not change either mask."""
    obj = v["depth"] > 0
    core = obj.copy()
    core[1:] &= obj[:-1]
    core[:-1] &= obj[1:]
    core[:, 1:] &= obj[:, :-1]
    core[:, :-1] &= obj[:, 1:]
    return [("map seen directly", ~obj), ("geometry (1 px eroded)", core)]


def bright_centroid(lum, cx, cy, rad, thresh):
    """Centroid and count of the pixels within rad of (cx, cy) brighter than thresh."""
    yy, xx = np.mgrid[0:lum.shape[0], 0:lum.shape[1]] + 0.5
    m = ((xx - cx) ** 2 + (yy - cy) ** 2 < rad ** 2) & (lum > thresh)
    if not m.any():
        return (float("nan"), float("nan"), 0)
    wts = lum * m
    return (float((xx * wts).sum() / wts.sum()), float((yy * wts).sum() / wts.sum()), int(m.sum()))


def srgb(x):
    x = np.clip(x, 0, 1)
    return np.where(x <= 0.0031308, 12.92 * x, 1.055 * np.power(x, 1 / 2.4) - 0.055)


def blocks(img, b=16):
    h, w = img.shape[:2]
    return img[: h // b * b, : w // b * b].reshape(h // b, b, w // b, b, -1).mean(axis=(1, 3))


def main():
    out, scenes = sys.argv[1], sys.argv[2:]
    md = ["| scene | channel | vkmech | Cycles | rel. diff | within 2 % |", "|---|---|---|---|---|---|"]
    md2 = ["| scene | vkmech s.e. of mean (lum) | left/right half rel. diff (lum) | block RMS rel. diff (region: lum. rel. diff) | vkmech wall s | Cycles wall s |",
           "|---|---|---|---|---|---|"]
    allok = True
    for s in scenes:
        v = read_exr(os.path.join(out, "vkmech", s + ".exr"))
        c = read_exr(os.path.join(out, "cycles", s + ".exr"))
        vi = np.stack([v[k] for k in "RGB"], -1)
        ci = np.stack([c[k] for k in "RGB"], -1)
        vt = json.load(open(os.path.join(out, "vkmech", s + ".json"))).get("wall_seconds", float("nan"))
        try:
            ct = float(open(os.path.join(out, "cycles", s + ".time")).read().split()[0])
        except OSError:
            ct = float("nan")
        n = v["R"].size
        spp = v["spp"]
        se = np.sqrt(np.sum(v["lum_var"] / spp)) / n
        lum = lambda im: 0.2126 * im[..., 0] + 0.7152 * im[..., 1] + 0.0722 * im[..., 2]
        vl, cl = lum(vi), lum(ci)
        w = vl.shape[1] // 2
        halves = [(vl[:, :w].mean() / cl[:, :w].mean() - 1), (vl[:, w:].mean() / cl[:, w:].mean() - 1)]
        bv, bc = blocks(vi), blocks(ci)
        rms = np.sqrt(np.mean((bv - bc) ** 2)) / np.mean(bc)
        print("== %s  (%dx%d, vkmech %d spp)" % (s, vi.shape[1], vi.shape[0], int(spp.mean())))
        print("   channel     vkmech     Cycles   rel.diff")
        for k, ch in enumerate("RGB"):
            a, b = vi[..., k].mean(), ci[..., k].mean()
            rd = a / b - 1
            ok = abs(rd) <= TOL
            allok &= ok
            print("   %s       %9.5f  %9.5f   %+7.2f %%  %s" % (ch, a, b, 100 * rd, "ok" if ok else "OUTSIDE 2 %"))
            md.append("| %s | %s | %.5f | %.5f | %+.2f %% | %s |" % (s, ch, a, b, 100 * rd, "yes" if ok else "**no**"))
        rois = gltf_rois(vi.shape[1]) if s == "val_gltf" else ROI.get(s, [])
        regions = instance_masks(vi.shape[1]) if s == "val_instances" else []
        if not rois and not regions and not s.startswith(("val_", "_")):
            regions = env_regions(v)  # a local scene (the DamagedHelmet check)
        for (name, cx, cy, r, *excl) in rois:
            k = vi.shape[1] / 128.0
            yy, xx = np.mgrid[0:vi.shape[0], 0:vi.shape[1]] + 0.5
            m = (xx - cx * k) ** 2 + (yy - cy * k) ** 2 < (r * k) ** 2
            for (ex, ey, er) in excl:
                m &= (xx - ex * k) ** 2 + (yy - ey * k) ** 2 >= (er * k) ** 2
            regions.append((name, m))
        for (name, m) in regions:
            for q, ch in enumerate("RGB"):
                a, b = vi[..., q][m].mean(), ci[..., q][m].mean()
                print("   %s region %s (%d px): %9.5f  %9.5f   %+7.2f %%" % (name, ch, m.sum(), a, b, 100 * (a / b - 1)))
                md.append("| %s (%s region, %d px) | %s | %.5f | %.5f | %+.2f %% | %s |" % (
                    s, name, m.sum(), ch, a, b, 100 * (a / b - 1), "yes" if abs(a / b - 1) <= TOL else "**no**"))
            rl = vl[m].mean()
            rse = np.sqrt(np.sum((v["lum_var"] / spp)[m])) / m.sum()
            print("   %s region: vkmech standard error of the mean luminance %.2f %%" % (name, 100 * rse / rl))
            md2.append("| %s (%s region) | %.2f %% | | %+.2f %% (lum) | | |" % (s, name, 100 * rse / rl, 100 * (rl / cl[m].mean() - 1)))
        print("   vkmech standard error of the mean luminance: %.3f %%" % (100 * se / vl.mean()))
        print("   luminance rel.diff left half %+.2f %%, right half %+.2f %%" % (100 * halves[0], 100 * halves[1]))
        print("   16x16-block RMS rel. difference: %.2f %%" % (100 * rms))
        if s == "val_envmap":
            # The sun disc's reflection in the mirror sphere (radiance ~ 0.95 x 1.5 x 300):
            # both renders must put it where the geometry says.
            k = vi.shape[1] / 128.0
            ex, ey, ew = sun_in_mirror(vi.shape[1])
            print("   sun in the mirror sphere, expected from the geometry: (%.2f, %.2f) px (%.1f px covered)" % (ex, ey, ew))
            for who, L in (("vkmech", vl), ("Cycles", cl)):
                bx, by, bn = bright_centroid(L, 64.0 * k, 62.4 * k, 17.4 * k, 20.0)
                print("   sun in the mirror sphere, %s: (%.2f, %.2f) px (%d px with luminance > 20)" % (who, bx, by, bn))
                md2.append("| %s: sun in the mirror sphere, %s | (%.2f, %.2f) px, %d px; expected (%.2f, %.2f) | | | | |"
                           % (s, who, bx, by, bn, ex, ey))
        if s == "val_gltf":
            # The directly seen sky: the environment map's orientation in both,
            # pixel for pixel (only sub-pixel jitter and interpolation remain).
            rows = gltf_sky_rows(vi.shape[0])
            a, b = vi[rows], ci[rows]
            rel = np.abs(a / b - 1)
            print("   directly seen sky, rows 0-%d (%d px): mean %s vs %s, max per-pixel |rel. diff| %.3f %%, mean %.4f %%"
                  % (rows[-1], a.shape[0] * a.shape[1], np.round(a.mean(axis=(0, 1)), 5), np.round(b.mean(axis=(0, 1)), 5),
                     100 * rel.max(), 100 * rel.mean()))
            md2.append("| %s: directly seen sky (rows 0-%d) | max per-pixel %.3f %%, mean %.4f %% | | | | |"
                       % (s, rows[-1], 100 * rel.max(), 100 * rel.mean()))
        if s == "val_instances":
            # Each instance's pixel box on its own: a wrong transform moves
            # one instance's pixels even where the regions' means hide it.
            rows = []
            for (y0, y1, x0, x1, _) in instance_boxes(vi.shape[0]):
                a, b = vl[y0:y1, x0:x1].sum(), cl[y0:y1, x0:x1].sum()
                rows.append((a / b - 1, np.sqrt(np.sum((v["lum_var"] / spp)[y0:y1, x0:x1])) / a))
            rel = np.array([r for r, _ in rows])
            z = np.array([r / e for r, e in rows])
            k = int(np.argmax(np.abs(rel)))
            print("   per-instance pixel boxes (%d): max |lum. rel. diff| %.2f %% (instance %d, %.1f vkmech s.e.), "
                  "RMS of rel. diff / vkmech s.e. %.2f" % (len(rows), 100 * abs(rel[k]), k, abs(z[k]), np.sqrt(np.mean(z ** 2))))
            md2.append("| %s: per-instance pixel boxes (%d) | max abs. lum. rel. diff %.2f %% (instance %d); RMS rel. diff / s.e. %.2f | | | | |"
                       % (s, len(rows), 100 * abs(rel[k]), k, np.sqrt(np.mean(z ** 2))))
        print("   wall time: vkmech %.1f s, Cycles %.1f s" % (vt, ct))
        md2.append("| %s | %.2f %% | %+.2f %% / %+.2f %% | %.2f %% | %.1f | %.1f |" % (
            s, 100 * se / vl.mean(), 100 * halves[0], 100 * halves[1], 100 * rms, vt, ct))
        try:
            import matplotlib
            matplotlib.use("Agg")
            import matplotlib.pyplot as plt
            gap = np.ones((vi.shape[0], 4, 3))
            plt.imsave(os.path.join(out, s + "_side_by_side.png"),
                       srgb(np.concatenate([vi, gap, ci], axis=1)).astype(np.float32))
        except Exception as e:  # previews are optional
            print("   (no preview: %s)" % e)
    with open(os.path.join(out, "results.md"), "w") as fh:
        fh.write("\n".join(md) + "\n\n" + "\n".join(md2) + "\n")
    print("all channel means within 2 %%: %s" % ("yes" if allok else "no"))


if __name__ == "__main__":
    main()
