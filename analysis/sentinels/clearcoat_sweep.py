#!/usr/bin/python3
"""The matpreview clearcoat sweep's hand-registered predictions 3 and 4
(docs/sentinels/paper-set/README.md), measured on four reference renders.

    PYTHONPATH=build/python clearcoat_sweep.py MASK.exr CC0.exr CC0.25.exr CC0.5.exr CC1.exr

MASK.exr is a render of the same camera in which the ball's exterior is an
emitter of radiance 1 and a black diffuse: its pixels with emitter_direct
energy are the ball's. Prints, as JSON: the share of pixels (labelled in both)
whose dominant label differs between the first and the last clearcoat value,
and, per clearcoat value, the mean and 90th percentile of the glossy energy
fraction gamma over the ball's labelled pixels (and over the whole image).
"""
import json
import sys

import numpy as np
import vkmech

NO_LABEL = 255


def main(argv):
    if len(argv) < 4:
        print(__doc__, file=sys.stderr)
        return 2
    mask_frame = vkmech.read(argv[1])
    ball = np.asarray(mask_frame["lum.emitter_direct"]) > 0
    frames = [vkmech.read(p) for p in argv[2:]]
    dom = [np.asarray(f["dominant"]).astype(int) for f in frames]
    gamma = [np.asarray(f["glossy_frac"]) for f in frames]
    first, last = dom[0], dom[-1]
    both = (first != NO_LABEL) & (last != NO_LABEL)
    out = {
        "ball_pixels": int(ball.sum()),
        "pixels_labelled_in_both": int(both.sum()),
        "label_changed_first_to_last": float(((first != last) & both).sum() / both.sum()),
        "per_render": [],
    }
    for path, d, g in zip(argv[2:], dom, gamma):
        lab = d != NO_LABEL
        on_ball = g[ball & lab]
        out["per_render"].append({
            "render": path,
            "ball_mean_gamma": float(on_ball.mean()),
            "ball_p90_gamma": float(np.quantile(on_ball, 0.9)),
            "image_mean_gamma": float(g[lab].mean()),
            "image_p90_gamma": float(np.quantile(g[lab], 0.9)),
        })
    means = [r["ball_mean_gamma"] for r in out["per_render"]]
    out["ball_mean_gamma_monotone_rising"] = all(b > a for a, b in zip(means, means[1:]))
    print(json.dumps(out, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
