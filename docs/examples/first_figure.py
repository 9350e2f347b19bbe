"""The paper's first figure from Python: the label is stable across a 64x budget change, sigma^2 is not.
Usage: PYTHONPATH=build/python /usr/bin/python3 docs/examples/first_figure.py [OUT.png [SCENE LOW HIGH RES]]"""
import json
import sys

import matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
import vkmech

out = sys.argv[1] if len(sys.argv) > 1 else "first_figure.png"
name, low, high, res = (sys.argv[2], *map(int, sys.argv[3:6])) if len(sys.argv) > 5 else ("glass_caustic", 64, 4096, 256)
scene = vkmech.load(name)
a, b = (vkmech.render(scene, spp=n, res=res, seed=seed) for n, seed in ((low, 1), (high, 2)))

agree = vkmech.stats.label_agreement(a["dominant"], b["dominant"])
lit = (a["lum_mean"] > 1e-4) & (b["lum_mean"] > 1e-4)  # background dropped, as the studies do
rho = vkmech.stats.spearman(a["lum_var"], b["lum_var"], mask=lit)

legend = json.loads(a.header["vkmech.dominantLegend"])  # {"0": "emitter_direct", ..., "255": "unlabelled"}
names = [legend[str(i)] for i in range(7)]
cmap = matplotlib.colors.ListedColormap(plt.cm.tab10.colors[:7])
fig, ax = plt.subplots(1, 5, figsize=(17, 3.9), constrained_layout=True)
ax[0].imshow(np.clip(a.rgb, 0, 1) ** (1 / 2.2))
ax[0].set_title(f"{name}, {low} spp")
for k, (f, n) in enumerate(((a, low), (b, high))):
    ax[1 + k].imshow(np.ma.masked_equal(f["dominant"], 255), cmap=cmap, vmin=-0.5, vmax=6.5, interpolation="nearest")
    ax[1 + k].set_title(f"label, {n} spp")
    im = ax[3 + k].imshow(np.log10(np.where(lit, f["lum_var"], np.nan) + 1e-8), cmap="magma", vmin=-6, vmax=2)
    ax[3 + k].set_title(f"log10 sigma^2, {n} spp")
fig.colorbar(im, ax=ax[4], shrink=0.8)
fig.legend(handles=[matplotlib.patches.Patch(color=cmap(i), label=names[i]) for i in range(7)], loc="upper center",
           bbox_to_anchor=(0.5, 0.0), ncol=7)
fig.suptitle(f"label agreement {agree['agreement']:.3f} (kappa {agree['kappa']:.3f}); "
             f"Spearman of sigma^2 {rho:.3f}, {low} vs {high} spp")
for x in ax:
    x.axis("off")
fig.savefig(out, dpi=80, bbox_inches="tight")
print(f"{out}: agreement {agree['agreement']:.4f}, kappa {agree['kappa']:.4f}, spearman(sigma^2) {rho:.4f}")
