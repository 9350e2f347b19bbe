#!/usr/bin/env python3
"""glTF principled spheres against Cycles, metallic x roughness (docs/validation.md,
"DamagedHelmet", what differs): six spheres of base colour (0.9, 0.6, 0.3), metallic 1.0 and
0.5, roughness 0.2, 0.5 and 0.8, each with a constant 4 x 4 metallicRoughnessTexture (so that
vkmech makes it `principled`, as it does the helmet) on a grey floor, lit only by --environment.

  metal_sweep.py write OUT                       # OUT/ms.gltf, ms.bin, textures/, meta.json
  metal_sweep.py compare OUT VKMECH.exr CYCLES.exr

compare prints the image's channel means and, per sphere, the mean RGB of a disc of 0.7 of its
projected radius, less the pixels whose camera ray meets another sphere first (the front row
hides part of the back row), in both renders and their relative difference.
"""
import json
import math
import os
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
import make_scenes as ms  # noqa: E402  (write_png, the glTF meshes, quat_axis)

CASES = [(m, r) for m in (1.0, 0.5) for r in (0.2, 0.5, 0.8)]
RADIUS = 0.35
CAM = ((0.0, 2.2, 4.2), (0.0, 0.35, 0.0), 40.0)  # origin, target, vertical fov (deg); glTF is +y up


def centre(k):
    return (-1.0 + 1.0 * (k % 3), RADIUS, -0.5 + 1.0 * (k // 3))


def write(out):
    os.makedirs(os.path.join(out, "textures"), exist_ok=True)
    g = ms.GltfBuffer()
    mesh = g.mesh
    images, materials = [], []

    def material(name, base, metallic, rough):
        png = "textures/mr_%s.png" % name  # linear: G roughness, B metallic
        ms.write_png(os.path.join(out, png), 4, 4, lambda x, y: (255, round(rough * 255), round(metallic * 255)))
        images.append({"uri": png})
        materials.append({"name": name, "pbrMetallicRoughness": {
            "baseColorFactor": base, "metallicRoughnessTexture": {"index": len(images) - 1}}})
        return len(materials) - 1

    (o, t, fov) = CAM
    pitch = math.degrees(math.atan2(o[1] - t[1], o[2] - t[2]))
    nodes = [{"name": "camera", "camera": 0, "translation": list(o), "rotation": ms.quat_axis((1, 0, 0), -pitch)},
             {"name": "floor", "mesh": mesh("floor", ms.gltf_floor_mesh(), material("floor", [0.5, 0.5, 0.5, 1], 0, 1))}]
    for k, (m, r) in enumerate(CASES):
        mat = material("s%d" % k, [0.9, 0.6, 0.3, 1], m, r)
        nodes.append({"name": "s%d" % k, "mesh": mesh("s%d" % k, ms.gltf_sphere_mesh(RADIUS), mat),
                      "translation": list(centre(k))})
    doc = {"asset": {"version": "2.0", "generator": "vkmech analysis/validation/metal_sweep.py"},
           "scene": 0, "scenes": [{"nodes": list(range(len(nodes)))}], "nodes": nodes,
           "cameras": [{"type": "perspective", "perspective": {"yfov": math.radians(fov), "aspectRatio": 1.0,
                                                                "znear": 0.01, "zfar": 1000.0}}],
           "meshes": g.meshes, "materials": materials, "images": images,
           "textures": [{"source": i, "sampler": 0} for i in range(len(images))],
           "samplers": [{"magFilter": 9728, "minFilter": 9728, "wrapS": 10497, "wrapT": 10497}],
           "accessors": g.accessors, "bufferViews": g.views, "buffers": [{"uri": "ms.bin", "byteLength": len(g.blob)}]}
    with open(os.path.join(out, "ms.bin"), "wb") as fh:
        fh.write(bytes(g.blob))
    with open(os.path.join(out, "ms.gltf"), "w") as fh:
        json.dump(doc, fh)
    print("metal_sweep.py: wrote %s/ms.gltf (%d spheres)" % (out, len(CASES)))


def compare(vk_path, cy_path):
    import numpy as np
    from exr import read_exr

    def rgb(p):
        d = read_exr(p)
        return np.stack([d["R"], d["G"], d["B"]], -1).astype(np.float64)

    a, b = rgb(vk_path), rgb(cy_path)
    res = a.shape[1]
    ma, mb = a.reshape(-1, 3).mean(0), b.reshape(-1, 3).mean(0)
    print("image: vkmech %s Cycles %s rel. diff %s %%" % (np.round(ma, 5), np.round(mb, 5), np.round((ma / mb - 1) * 100, 2)))
    (o, t, fov) = (np.array(CAM[0]), np.array(CAM[1]), CAM[2])
    f = (t - o) / np.linalg.norm(t - o)
    right = np.cross(f, [0, 1, 0])
    right /= np.linalg.norm(right)
    up = np.cross(right, f)
    tan_half = math.tan(math.radians(fov) / 2)
    yy, xx = np.mgrid[0:a.shape[0], 0:res]
    # Each pixel centre's camera ray against the six spheres: which one it sees first (the front
    # row hides part of the back row), so that a sphere's region holds only its own pixels.
    dirs = (f[None, None, :] + ((2 * (xx + 0.5) / res - 1) * tan_half)[..., None] * right
            + ((1 - 2 * (yy + 0.5) / res) * tan_half)[..., None] * up)
    dirs /= np.linalg.norm(dirs, axis=-1, keepdims=True)
    nearest, first = np.full(xx.shape, np.inf), np.full(xx.shape, -1)
    for k in range(len(CASES)):
        oc = o - np.array(centre(k))
        bq = dirs @ oc
        disc = bq ** 2 - (oc @ oc - RADIUS ** 2)
        t = np.where(disc > 0, -bq - np.sqrt(np.maximum(disc, 0)), np.inf)
        closer = (t > 0) & (t < nearest)
        nearest, first = np.where(closer, t, nearest), np.where(closer, k, first)
    for k, (m, r) in enumerate(CASES):
        d = np.array(centre(k)) - o
        z = d @ f
        px = (d @ right / (z * tan_half) + 1) / 2 * res
        py = (1 - d @ up / (z * tan_half)) / 2 * res
        rad = 0.7 * RADIUS / (z * tan_half) * res / 2
        mask = ((xx + 0.5 - px) ** 2 + (yy + 0.5 - py) ** 2 < rad ** 2) & (first == k)
        va, vb = a[mask].mean(0), b[mask].mean(0)
        print("metallic %.1f roughness %.1f (%d px): vkmech %s Cycles %s rel. diff %s %%" % (
            m, r, mask.sum(), np.round(va, 4), np.round(vb, 4), np.round((va / vb - 1) * 100, 2)))


if __name__ == "__main__":
    if sys.argv[1:2] == ["write"] and len(sys.argv) == 3:
        write(sys.argv[2])
    elif sys.argv[1:2] == ["compare"] and len(sys.argv) == 5:
        compare(sys.argv[3], sys.argv[4])
    else:
        sys.exit(__doc__)
