"""Minimal OpenEXR reader (numpy + zlib only): single-part scanline files,
NONE / ZIPS / ZIP compression, HALF / FLOAT / UINT channels.  Enough for
vkmech's EXR (ZIP, float) and Blender's (written here as ZIP, float)."""
import struct
import zlib

import numpy as np

_DT = {0: np.uint32, 1: np.float16, 2: np.float32}
_SZ = {0: 4, 1: 2, 2: 4}


def _cstr(b, p):
    e = b.index(b"\0", p)
    return b[p:e].decode("latin-1"), e + 1


def read_exr(path):
    """Return {channel name: float64 array (height, width)}."""
    b = open(path, "rb").read()
    if struct.unpack_from("<I", b, 0)[0] != 20000630:
        raise ValueError(path + ": not an OpenEXR file")
    flags = struct.unpack_from("<I", b, 4)[0]
    if flags & 0x1a00:  # tiled, multipart or deep
        raise ValueError(path + ": only single-part scanline EXR supported")
    p, attrs = 8, {}
    while True:
        name, p = _cstr(b, p)
        if not name:
            break
        typ, p = _cstr(b, p)
        size = struct.unpack_from("<i", b, p)[0]
        p += 4
        attrs[name] = (typ, b[p:p + size])
        p += size
    chans, q, cl = [], 0, attrs["channels"][1]
    while cl[q] != 0:
        cname, q = _cstr(cl, q)
        ptype = struct.unpack_from("<i", cl, q)[0]
        xs, ys = struct.unpack_from("<ii", cl, q + 8)
        if xs != 1 or ys != 1:
            raise ValueError(path + ": subsampled channels not supported")
        chans.append((cname, ptype))
        q += 16
    comp = attrs["compression"][1][0]
    if comp not in (0, 2, 3):
        raise ValueError(path + ": compression %d not supported" % comp)
    x0, y0, x1, y1 = struct.unpack("<iiii", attrs["dataWindow"][1])
    w, h = x1 - x0 + 1, y1 - y0 + 1
    lines = {0: 1, 2: 1, 3: 16}[comp]
    nchunks = (h + lines - 1) // lines
    offsets = struct.unpack_from("<%dQ" % nchunks, b, p)
    out = {c: np.zeros((h, w), np.float64) for c, _ in chans}
    for off in offsets:
        y, size = struct.unpack_from("<ii", b, off)
        data = b[off + 8: off + 8 + size]
        n = min(lines, y1 + 1 - y)
        expect = n * w * sum(_SZ[t] for _, t in chans)
        if comp != 0 and size < expect:
            t = np.frombuffer(zlib.decompress(data), np.uint8).astype(np.int32)
            t = (np.cumsum(np.concatenate([t[:1], t[1:] - 128])) & 0xFF).astype(np.uint8)
            half = (len(t) + 1) // 2
            u = np.empty_like(t)
            u[0::2], u[1::2] = t[:half], t[half:]
            data = u.tobytes()
        pos = 0
        for r in range(n):
            for c, t in chans:
                cnt = w * _SZ[t]
                out[c][y - y0 + r] = np.frombuffer(data[pos:pos + cnt], _DT[t]).astype(np.float64)
                pos += cnt
    return out
