"""Copy a glTF 2.0 file that has no camera, adding the camera vkmech frames it
with, so that blender_scene.py (which needs a camera node) and vkmech render
it from the same viewpoint.

  /usr/bin/python3 analysis/validation/gltf_with_camera.py IN.glb|IN.gltf OUT [--no-normal-texture]
      [--no-emission] [--metallic-factor M] [--nearest] [--flat]

The camera is vkmech's framing camera (host/engine/scene/gltf_loader.cpp,
framing_camera; docs/descriptor.md §8): from +z, looking along -z, +y up,
yfov 45 degrees, aspect 1, at c + (0, 0, d) with c the centre of the scene's
world-space bounds, r half their diagonal and d = r / sin(22.5 degrees). The
bounds are those of every vertex position under its node's world transform.
vkmech prints the camera's position in its warning for the original file;
compare it with the position printed here.

The options write variants for isolating a difference (each applies to every
material): drop normalTexture; drop emissiveTexture and set emissiveFactor 0;
set pbrMetallicRoughness.metallicFactor; set every sampler's filters to
NEAREST; drop every primitive's NORMAL attribute (flat shading in both).

A .glb is rewritten whole; a .gltf's output must be in the input's directory
(its buffers and images are referred to by relative URIs). Only what the
bounds need is read: float VEC3 positions, no sparse accessors, no skins or
morph targets.
"""
import json
import math
import os
import struct
import sys

import numpy as np


def die(msg):
    print("gltf_with_camera.py: " + msg, file=sys.stderr)
    sys.exit(2)


def read(path):
    """The JSON and the buffers' bytes (a GLB's BIN chunk is buffer 0)."""
    data = open(path, "rb").read()
    if data[:4] == b"glTF":
        _, _, _ = struct.unpack("<III", data[:12])
        jlen, jtype = struct.unpack("<II", data[12:20])
        if jtype != 0x4E4F534A:
            die("the first GLB chunk is not JSON")
        j = json.loads(data[20:20 + jlen])
        rest = data[20 + jlen:]
        bins = []
        if rest:
            blen, btype = struct.unpack("<II", rest[:8])
            bins = [rest[8:8 + blen]]
        return j, bins, rest, True
    j = json.loads(data)
    base = os.path.dirname(os.path.abspath(path))
    bins = []
    for b in j.get("buffers", []):
        uri = b.get("uri", "")
        if uri.startswith("data:"):
            import base64
            bins.append(base64.b64decode(uri.split(",", 1)[1]))
        else:
            from urllib.parse import unquote
            bins.append(open(os.path.join(base, unquote(uri)), "rb").read())
    return j, bins, None, False


def node_matrix(n):
    if "matrix" in n:
        return np.array(n["matrix"], dtype=float).reshape(4, 4).T  # column-major
    t = n.get("translation", [0, 0, 0])
    x, y, z, w = n.get("rotation", [0, 0, 0, 1])
    s = n.get("scale", [1, 1, 1])
    R = np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                  [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                  [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])
    M = np.eye(4)
    M[:3, :3] = R @ np.diag(s)
    M[:3, 3] = t
    return M


def positions(j, bins, a):
    acc = j["accessors"][a]
    if acc.get("sparse") or acc["componentType"] != 5126 or acc["type"] != "VEC3":
        die("accessor %d: only dense float VEC3 positions" % a)
    bv = j["bufferViews"][acc["bufferView"]]
    off = bv.get("byteOffset", 0) + acc.get("byteOffset", 0)
    stride = bv.get("byteStride", 12)
    buf = bins[bv["buffer"]]
    n = acc["count"]
    raw = np.frombuffer(buf, dtype=np.uint8, count=(n - 1) * stride + 12, offset=off)
    return np.lib.stride_tricks.as_strided(raw, (n, 12), (stride, 1)).copy().view("<f4").reshape(n, 3).astype(float)


def bounds(j, bins):
    lo, hi = np.full(3, np.inf), np.full(3, -np.inf)
    scene = j["scenes"][j.get("scene", 0)]
    stack = [(n, np.eye(4)) for n in scene["nodes"]]
    while stack:
        i, P = stack.pop()
        n = j["nodes"][i]
        if "skin" in n:
            die("node %d: skins are not handled" % i)
        M = P @ node_matrix(n)
        if "camera" in n:
            die("the file already has a camera (node %d)" % i)
        if "mesh" in n:
            for p in j["meshes"][n["mesh"]]["primitives"]:
                if p.get("targets"):
                    die("mesh %d: morph targets are not handled" % n["mesh"])
                v = positions(j, bins, p["attributes"]["POSITION"])
                w = v @ M[:3, :3].T + M[:3, 3]
                lo, hi = np.minimum(lo, w.min(0)), np.maximum(hi, w.max(0))
        stack += [(c, M) for c in n.get("children", [])]
    return lo, hi


def main():
    args = sys.argv[1:]
    if len(args) < 2:
        die("usage: IN.glb|IN.gltf OUT [--no-normal-texture] [--no-emission] [--metallic-factor M] [--nearest] [--flat]")
    src, dst, opts = args[0], args[1], args[2:]
    j, bins, rest, glb = read(src)
    lo, hi = bounds(j, bins)
    c = 0.5 * (lo + hi)
    r = max(0.5 * float(np.linalg.norm(hi - lo)), 1e-6)
    d = r / math.sin(math.radians(22.5))
    flags, metallic, k = set(), None, 0
    while k < len(opts):
        if opts[k] == "--metallic-factor" and k + 1 < len(opts):
            metallic, k = float(opts[k + 1]), k + 2
        elif opts[k] in ("--no-normal-texture", "--no-emission", "--nearest", "--flat"):
            flags.add(opts[k])
            k += 1
        else:
            die("unknown option " + opts[k])
    for m in j.get("materials", []):
        if "--no-normal-texture" in flags:
            m.pop("normalTexture", None)
        if "--no-emission" in flags:
            m.pop("emissiveTexture", None)
            m["emissiveFactor"] = [0, 0, 0]
        if metallic is not None:
            m.setdefault("pbrMetallicRoughness", {})["metallicFactor"] = metallic
    if "--nearest" in flags:
        for smp in j.get("samplers", []):
            smp["magFilter"] = smp["minFilter"] = 9728
    if "--flat" in flags:
        for me in j["meshes"]:
            for p in me["primitives"]:
                p["attributes"].pop("NORMAL", None)
    j.setdefault("cameras", []).append({
        "type": "perspective", "name": "vkmech framing camera",
        "perspective": {"yfov": math.radians(45.0), "aspectRatio": 1.0, "znear": 0.5 * (d - r), "zfar": 2.0 * (d + r)}})
    j["nodes"].append({"name": "vkmech framing camera", "camera": len(j["cameras"]) - 1,
                       "translation": [float(c[0]), float(c[1]), float(c[2] + d)]})
    j["scenes"][j.get("scene", 0)]["nodes"].append(len(j["nodes"]) - 1)
    if glb:
        js = json.dumps(j, separators=(",", ":")).encode()
        js += b" " * (-len(js) % 4)
        with open(dst, "wb") as f:
            f.write(struct.pack("<III", 0x46546C67, 2, 20 + len(js) + len(rest)))
            f.write(struct.pack("<II", len(js), 0x4E4F534A) + js + rest)
    else:
        if os.path.dirname(os.path.abspath(dst)) != os.path.dirname(os.path.abspath(src)):
            die("a .gltf copy must be written next to the original (relative URIs)")
        with open(dst, "w") as f:
            json.dump(j, f, indent=1)
    print("gltf_with_camera.py: bounds %s .. %s; camera at (%.6g, %.6g, %.6g), yfov 45 deg, looking along -z%s" % (
        np.round(lo, 6), np.round(hi, 6), c[0], c[1], c[2] + d, (" (variant: %s)" % " ".join(opts)) if opts else ""))


main()
