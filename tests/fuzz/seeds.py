#!/usr/bin/env python3
"""Writes the loader fuzzer's seed corpus into DIR: every scene, mesh and
image file under tests/data (one selector byte in front: see fuzz_loader.cpp),
plus a Mitsuba serialized mesh and glTF / GLB files made here, since the unit
tests make theirs at run time."""
import base64, json, pathlib, struct, sys, zlib

SELECTOR = {".xml": 0, ".obj": 1, ".ply": 2, ".serialized": 3, ".gltf": 4, ".glb": 5, ".png": 6}


def serialized_quad():
    verts = [(-1, -1, 0), (1, -1, 0), (1, 1, 0), (-1, 1, 0)]
    normals = [(0, 0, 1)] * 4
    uvs = [(0, 0), (1, 0), (1, 1), (0, 1)]
    body = struct.pack("<I", 0x0001 | 0x0002 | 0x1000) + b"quad\0" + struct.pack("<QQ", 4, 2)
    for v in verts + normals:
        body += struct.pack("<3f", *v)
    for uv in uvs:
        body += struct.pack("<2f", *uv)
    body += struct.pack("<6I", 0, 1, 2, 0, 2, 3)
    mesh = struct.pack("<HH", 0x041C, 4) + zlib.compress(body)
    return mesh + struct.pack("<QI", 0, 1)


def gltf_triangle():
    pos = struct.pack("<9f", 0, 0, 0, 1, 0, 0, 0, 1, 0)
    idx = struct.pack("<3H", 0, 1, 2) + b"\0\0"
    buf = pos + idx
    doc = {
        "asset": {"version": "2.0"},
        "scene": 0,
        "scenes": [{"nodes": [0, 1, 2]}],
        "nodes": [{"mesh": 0}, {"camera": 0, "translation": [0.3, 0.3, 3]},
                  {"mesh": 0, "scale": [2, 2, 2], "translation": [0, 0, 2]}],
        "cameras": [{"type": "perspective", "perspective": {"yfov": 0.8, "znear": 0.01}}],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "indices": 1, "material": 0}]}],
        "materials": [{"pbrMetallicRoughness": {"baseColorFactor": [0.8, 0.8, 0.8, 1]},
                       "emissiveFactor": [1, 1, 1]}],
        "buffers": [{"byteLength": len(buf),
                     "uri": "data:application/octet-stream;base64," + base64.b64encode(buf).decode()}],
        "bufferViews": [{"buffer": 0, "byteOffset": 0, "byteLength": 36},
                        {"buffer": 0, "byteOffset": 36, "byteLength": 6}],
        "accessors": [{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3",
                       "min": [0, 0, 0], "max": [1, 1, 0]},
                      {"bufferView": 1, "componentType": 5123, "count": 3, "type": "SCALAR"}],
    }
    text = json.dumps(doc).encode()
    # GLB: the same document with the buffer in the binary chunk.
    del doc["buffers"][0]["uri"]
    j = json.dumps(doc).encode()
    j += b" " * (-len(j) % 4)
    b = buf + b"\0" * (-len(buf) % 4)
    glb = struct.pack("<III", 0x46546C67, 2, 12 + 8 + len(j) + 8 + len(b))
    glb += struct.pack("<II", len(j), 0x4E4F534A) + j + struct.pack("<II", len(b), 0x004E4942) + b
    return text, glb


def main():
    root = pathlib.Path(__file__).resolve().parents[1] / "data"
    out = pathlib.Path(sys.argv[1])
    out.mkdir(parents=True, exist_ok=True)
    n = 0
    for f in sorted(root.rglob("*")):
        sel = SELECTOR.get(f.suffix.lower())
        if f.is_file() and sel is not None:
            (out / f"data_{n:03d}{f.suffix}").write_bytes(bytes([sel]) + f.read_bytes())
            n += 1
    text, glb = gltf_triangle()
    for name, sel, data in (("quad.serialized", 3, serialized_quad()), ("tri.gltf", 4, text), ("tri.glb", 5, glb)):
        (out / f"made_{name}").write_bytes(bytes([sel]) + data)
        n += 1
    print(f"seeds.py: {n} seeds in {out}")


main()
