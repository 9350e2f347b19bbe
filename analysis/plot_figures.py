#!/usr/bin/env python3
"""Draw vkmech figure specifications (JSON) as PNG files with matplotlib.

Usage:
    python3 analysis/plot_figures.py FILE_OR_DIR...

Each argument is a spec file, or a directory whose ``*.json`` files (sorted,
not recursive) are all drawn.  For every spec ``DIR/NAME.json`` the figure is
written to ``DIR/NAME.png`` atomically (a temporary file in the same directory,
then ``os.replace``), and the PNG's path is printed on its own line.

Exit status: 0 when every spec was drawn; 2 when any argument or spec was bad
(each problem is reported on stderr as ``plot_figures: FILE: what is wrong``,
and the remaining specs are still drawn); 3 when matplotlib is unavailable.

Output is deterministic: matplotlib's built-in defaults are used (any
matplotlibrc is ignored), the figure size and dpi depend only on the spec, and
no software/version metadata is embedded in the PNG, so the same spec always
gives byte-identical files.

The C++ side (analysis/report/figure.cpp) writes these specs; the numbers
plotted are exactly the ones it computed.

Spec schema (every key not marked required is optional; an empty string means
"not given"; unknown keys are ignored with a warning on stderr):

    {
      "title":      "figure title",
      "caption":    "text printed, wrapped, under the figure",
      "columns":    3,            # panels per row; default min(3, #panels)
      "panel_size": [4.0, 3.2],   # inches per panel (width, height)
      "dpi":        120,          # default 120
      "panels": [                 # required, at least one
        {
          "kind":   "line" | "scatter" | "bar",       # required
          "title":  "...", "xlabel": "...", "ylabel": "...",
          "logx":   false, "logy": false,              # logx ignored for bar
          "xlim":   [lo, hi], "ylim": [lo, hi],        # either end may be null = auto
          "categories": ["direct", "glossy", ...],    # bar: required x categories
          "series": [
            {
              "label":  "legend text",
              "x":      [numbers or null],   # line/scatter (default 0..n-1); ignored for bar
              "y":      [numbers or null],   # required; null = missing (gap / no bar)
              "lo": [..], "hi": [..],        # same length as y, null = none;
                                             #   line    -> shaded band between lo and hi
                                             #   scatter -> vertical error bars
                                             #   bar     -> asymmetric error bars
              "color":  "#rrggbb",           # any matplotlib colour; default colour cycle
              "marker": "o",                 # line default none, scatter default "o"
              "linestyle": "-" | "--" | ":" | "-." | "none",   # line only, default "-"
              "size":   4,                   # marker size in points (line and scatter); 0 = default
              "alpha":  0.5,                 # opacity of the series (band: alpha / 4); 0 = default
              "lower_bound": [bool, ...]     # bar only, same length as y: censored bars
                                             #   (true value >= bar) are hatched and
                                             #   labelled with a "≥" above the bar
            }
          ],
          "hlines": [{"y": 0.95, "label": "95%", "linestyle": "--", "color": "#888888"}],
          "diagonal": false,                 # draw y = x (predicted vs actual)
          "legend":   true,                  # default: true when any series or hline has a label
          "annotations": [{"x": 1, "y": 2, "text": "..."}]
        }
      ]
    }

Bar panels with several series draw grouped bars side by side over the
categories, one colour and legend entry per series.  Grid cells beyond the
number of panels are hidden.  A spec with no panels, an unknown kind, a wrong
type, or arrays of mismatched lengths is an error.
"""

import json
import math
import os
import sys
import tempfile
import textwrap

PROG = "plot_figures"


def _import_matplotlib():
    """Imports matplotlib with the Agg backend. When the interpreter running
    this script has no matplotlib (e.g. a pyenv python3 first on PATH), re-runs
    the script once under Debian's /usr/bin/python3, which python3-matplotlib
    installs into."""
    try:
        import matplotlib
    except ImportError:
        alt = "/usr/bin/python3"
        if (os.environ.get("PLOT_FIGURES_REEXEC") != "1" and os.path.exists(alt)
                and os.path.realpath(alt) != os.path.realpath(sys.executable)):
            env = dict(os.environ, PLOT_FIGURES_REEXEC="1")
            sys.stdout.flush()
            sys.stderr.flush()
            os.execve(alt, [alt, os.path.abspath(__file__)] + sys.argv[1:], env)
        sys.stderr.write(f"{PROG}: matplotlib is not installed "
                         "(Debian: apt-get install python3-matplotlib)\n")
        sys.exit(3)
    matplotlib.use("Agg")
    return matplotlib


class SpecError(Exception):
    pass


# --------------------------------------------------------------------------
# Validation: turns the raw JSON into plain, checked Python values.
# --------------------------------------------------------------------------

LINESTYLES = {"-": "-", "--": "--", ":": ":", "-.": "-.", "none": "none", "": "none",
              "solid": "-", "dashed": "--", "dotted": ":", "dashdot": "-."}

FIGURE_KEYS = {"title", "caption", "columns", "panel_size", "dpi", "panels"}
PANEL_KEYS = {"kind", "title", "xlabel", "ylabel", "logx", "logy", "xlim", "ylim",
              "categories", "series", "hlines", "diagonal", "legend", "annotations"}
SERIES_KEYS = {"label", "x", "y", "lo", "hi", "color", "marker", "linestyle", "size",
               "alpha", "lower_bound"}
HLINE_KEYS = {"y", "label", "linestyle", "color"}
ANNOTATION_KEYS = {"x", "y", "text"}


class Checker:
    def __init__(self, warn):
        self.warn = warn

    def obj(self, v, where, keys):
        if not isinstance(v, dict):
            raise SpecError(f"{where}: expected an object, got {type(v).__name__}")
        for k in sorted(set(v) - keys):
            self.warn(f"{where}: unknown key '{k}' ignored")
        return v

    @staticmethod
    def is_num(v):
        return isinstance(v, (int, float)) and not isinstance(v, bool)

    def text(self, d, key, where):
        v = d.get(key)
        if v is None:
            return ""
        if not isinstance(v, str):
            raise SpecError(f"{where}.{key}: expected a string, got {type(v).__name__}")
        return v

    def flag(self, d, key, where, default=False):
        v = d.get(key)
        if v is None:
            return default
        if not isinstance(v, bool):
            raise SpecError(f"{where}.{key}: expected true or false")
        return v

    def number(self, d, key, where, default=None, positive=False, lo=None, hi=None):
        v = d.get(key)
        if v is None:
            if default is None:
                raise SpecError(f"{where}.{key}: required number is missing")
            return default
        if not self.is_num(v) or not math.isfinite(v):
            raise SpecError(f"{where}.{key}: expected a finite number, got {json.dumps(v)}")
        if positive and v <= 0:
            raise SpecError(f"{where}.{key}: must be > 0, got {v}")
        if (lo is not None and v < lo) or (hi is not None and v > hi):
            raise SpecError(f"{where}.{key}: must be in [{lo}, {hi}], got {v}")
        return float(v)

    def numbers(self, d, key, where, required=False):
        """List of numbers where null (or a non-finite value) means missing -> NaN."""
        v = d.get(key)
        if v is None:
            if required:
                raise SpecError(f"{where}.{key}: required list is missing")
            return None
        if not isinstance(v, list):
            raise SpecError(f"{where}.{key}: expected a list of numbers, got {type(v).__name__}")
        out = []
        for i, e in enumerate(v):
            if e is None:
                out.append(math.nan)
            elif self.is_num(e):
                out.append(float(e) if math.isfinite(e) else math.nan)
            else:
                raise SpecError(f"{where}.{key}[{i}]: expected a number or null, got {json.dumps(e)}")
        return out

    def limits(self, d, key, where):
        v = d.get(key)
        if v is None:
            return None
        if not isinstance(v, list) or len(v) != 2:
            raise SpecError(f"{where}.{key}: expected [lo, hi]")
        out = []
        for i, e in enumerate(v):
            if e is None:
                out.append(None)
            elif self.is_num(e) and math.isfinite(e):
                out.append(float(e))
            else:
                raise SpecError(f"{where}.{key}[{i}]: expected a number or null")
        if out[0] is not None and out[1] is not None and not out[0] < out[1]:
            raise SpecError(f"{where}.{key}: lo must be < hi, got {v}")
        return out

    def color(self, d, key, where, colors):
        v = self.text(d, key, where)
        if v and not colors.is_color_like(v):
            raise SpecError(f"{where}.{key}: not a colour: {v!r}")
        return v or None

    def linestyle(self, d, key, where, default):
        v = d.get(key)
        if v is None:
            return default
        if not isinstance(v, str) or v not in LINESTYLES:
            raise SpecError(f"{where}.{key}: expected one of '-', '--', ':', '-.', 'none', got {json.dumps(v)}")
        return LINESTYLES[v]


def check_spec(raw, warn):
    """Validates a parsed spec and returns a normalised dict."""
    import matplotlib.colors as mcolors
    from matplotlib.markers import MarkerStyle

    c = Checker(warn)
    c.obj(raw, "spec", FIGURE_KEYS)
    fig = {
        "title": c.text(raw, "title", "spec"),
        "caption": c.text(raw, "caption", "spec"),
        "dpi": c.number(raw, "dpi", "spec", default=120.0, lo=20, hi=600),
    }
    panels = raw.get("panels")
    if panels is None:
        raise SpecError("spec.panels: missing")
    if not isinstance(panels, list):
        raise SpecError("spec.panels: expected a list")
    if not panels:
        raise SpecError("spec.panels: no panels")
    cols = raw.get("columns")
    if cols is None or cols == 0:
        cols = min(3, len(panels))
    elif not isinstance(cols, int) or isinstance(cols, bool) or cols < 0:
        raise SpecError(f"spec.columns: expected a positive integer, got {json.dumps(cols)}")
    fig["columns"] = max(1, min(cols, len(panels)))
    ps = raw.get("panel_size")
    if ps is None:
        fig["panel_size"] = (4.0, 3.2)
    else:
        if (not isinstance(ps, list) or len(ps) != 2
                or not all(c.is_num(e) and math.isfinite(e) and 0.5 <= e <= 30 for e in ps)):
            raise SpecError(f"spec.panel_size: expected [width, height] in inches (0.5..30), got {json.dumps(ps)}")
        fig["panel_size"] = (float(ps[0]), float(ps[1]))

    fig["panels"] = []
    for pi, rp in enumerate(panels):
        w = f"panels[{pi}]"
        c.obj(rp, w, PANEL_KEYS)
        kind = rp.get("kind")
        if kind not in ("line", "scatter", "bar"):
            raise SpecError(f"{w}.kind: unknown kind {json.dumps(kind)} (expected line, scatter or bar)")
        p = {
            "kind": kind,
            "title": c.text(rp, "title", w),
            "xlabel": c.text(rp, "xlabel", w),
            "ylabel": c.text(rp, "ylabel", w),
            "logx": c.flag(rp, "logx", w),
            "logy": c.flag(rp, "logy", w),
            "xlim": c.limits(rp, "xlim", w),
            "ylim": c.limits(rp, "ylim", w),
            "diagonal": c.flag(rp, "diagonal", w),
        }
        cats = rp.get("categories")
        if kind == "bar":
            if not isinstance(cats, list) or not cats:
                raise SpecError(f"{w}.categories: a bar panel needs a non-empty list of categories")
            if not all(isinstance(e, str) for e in cats):
                raise SpecError(f"{w}.categories: expected strings")
            p["categories"] = list(cats)
        elif cats is not None and not isinstance(cats, list):
            raise SpecError(f"{w}.categories: expected a list of strings")

        series = rp.get("series", [])
        if not isinstance(series, list):
            raise SpecError(f"{w}.series: expected a list")
        p["series"] = []
        for si, rs in enumerate(series):
            sw = f"{w}.series[{si}]"
            c.obj(rs, sw, SERIES_KEYS)
            y = c.numbers(rs, "y", sw, required=True)
            n = len(y)
            s = {"label": c.text(rs, "label", sw), "y": y}
            if kind == "bar":
                if n != len(p["categories"]):
                    raise SpecError(f"{sw}.y: {n} values for {len(p['categories'])} categories")
                s["x"] = None
            else:
                x = c.numbers(rs, "x", sw)
                if x is None:
                    x = [float(i) for i in range(n)]
                if len(x) != n:
                    raise SpecError(f"{sw}: x has {len(x)} values but y has {n}")
                s["x"] = x
            lo, hi = c.numbers(rs, "lo", sw), c.numbers(rs, "hi", sw)
            if (lo is None) != (hi is None):
                raise SpecError(f"{sw}: lo and hi must be given together")
            for name, arr in (("lo", lo), ("hi", hi)):
                if arr is not None and len(arr) != n:
                    raise SpecError(f"{sw}.{name}: {len(arr)} values but y has {n}")
            s["lo"], s["hi"] = lo, hi
            s["color"] = c.color(rs, "color", sw, mcolors)
            marker = rs.get("marker")
            if marker is not None and marker != "":
                if not isinstance(marker, str):
                    raise SpecError(f"{sw}.marker: expected a string")
                try:
                    MarkerStyle(marker)
                except (ValueError, TypeError):
                    raise SpecError(f"{sw}.marker: not a matplotlib marker: {marker!r}") from None
            s["marker"] = marker or None
            s["linestyle"] = c.linestyle(rs, "linestyle", sw, "-")
            # 0 means "default" for size and alpha (the C++ writer's convention).
            s["size"] = c.number(rs, "size", sw, default=0.0, lo=0, hi=100) or None
            s["alpha"] = c.number(rs, "alpha", sw, default=0.0, lo=0, hi=1) or None
            lb = rs.get("lower_bound")
            if kind != "bar" or lb is None or lb == []:  # bar only: ignored elsewhere
                s["lower_bound"] = [False] * n
            else:
                if not isinstance(lb, list) or not all(isinstance(e, bool) for e in lb):
                    raise SpecError(f"{sw}.lower_bound: expected a list of true/false")
                if len(lb) != n:
                    raise SpecError(f"{sw}.lower_bound: {len(lb)} values but y has {n}")
                s["lower_bound"] = list(lb)
            p["series"].append(s)

        hl = rp.get("hlines", [])
        if not isinstance(hl, list):
            raise SpecError(f"{w}.hlines: expected a list")
        p["hlines"] = []
        for hi_, rh in enumerate(hl):
            hw = f"{w}.hlines[{hi_}]"
            c.obj(rh, hw, HLINE_KEYS)
            p["hlines"].append({
                "y": c.number(rh, "y", hw),
                "label": c.text(rh, "label", hw),
                "linestyle": c.linestyle(rh, "linestyle", hw, "--"),
                "color": c.color(rh, "color", hw, mcolors) or "#888888",
            })

        an = rp.get("annotations", [])
        if not isinstance(an, list):
            raise SpecError(f"{w}.annotations: expected a list")
        p["annotations"] = []
        for ai, ra in enumerate(an):
            aw = f"{w}.annotations[{ai}]"
            c.obj(ra, aw, ANNOTATION_KEYS)
            if kind == "bar" and isinstance(ra.get("x"), str):
                if ra["x"] not in p["categories"]:
                    raise SpecError(f"{aw}.x: unknown category {ra['x']!r}")
                x = float(p["categories"].index(ra["x"]))
            else:
                x = c.number(ra, "x", aw)
            p["annotations"].append({"x": x, "y": c.number(ra, "y", aw), "text": c.text(ra, "text", aw)})

        any_label = any(s["label"] for s in p["series"]) or any(h["label"] for h in p["hlines"])
        p["legend"] = c.flag(rp, "legend", w, default=any_label)
        fig["panels"].append(p)
    return fig


# --------------------------------------------------------------------------
# Drawing
# --------------------------------------------------------------------------

def _fonts(npanels):
    big = npanels <= 2
    return {
        "font.size": 9 if big else 8,
        "axes.titlesize": 9.5 if big else 8.5,
        "axes.labelsize": 9 if big else 8,
        "xtick.labelsize": 8 if big else 7.5,
        "ytick.labelsize": 8 if big else 7.5,
        "legend.fontsize": 7 if big else 6.5,
        "figure.titlesize": 11,
    }


def _nan_masked(np, v):
    return np.ma.masked_invalid(np.asarray(v, dtype=float))


def _draw_line(ax, p, np, colors):
    for s, col in zip(p["series"], colors):
        x, y = np.asarray(s["x"]), np.asarray(s["y"])
        order = np.argsort(x, kind="stable")  # gaps come from NaN y / x
        x, y = x[order], y[order]
        marker = s["marker"]
        ls = s["linestyle"]
        finite = np.isfinite(x) & np.isfinite(y)
        if marker is None and (ls == "none" or finite.sum() == 1):
            marker = "o"  # otherwise the series would be invisible
        kw = {}
        if s["size"] is not None:
            kw["markersize"] = s["size"]
        # A NaN x would break the line at an arbitrary place: drop those points.
        keep = np.isfinite(x)
        ax.plot(x[keep], y[keep], color=col, marker=marker or "", linestyle=ls,
                linewidth=1.4, alpha=s["alpha"], label=s["label"] or "_nolegend_",
                zorder=3, **kw)
        if s["lo"] is not None:
            lo, hi = np.asarray(s["lo"])[order][keep], np.asarray(s["hi"])[order][keep]
            ok = np.isfinite(lo) & np.isfinite(hi)
            a = 0.22 if s["alpha"] is None else s["alpha"] / 4.0
            ax.fill_between(x[keep], lo, hi, where=ok, interpolate=False, color=col,
                            alpha=a, linewidth=0, zorder=2)


def _draw_scatter(ax, p, np, colors):
    from matplotlib.markers import MarkerStyle
    for s, col in zip(p["series"], colors):
        x, y = np.asarray(s["x"]), np.asarray(s["y"])
        ok = np.isfinite(x) & np.isfinite(y)
        size = 5.0 if s["size"] is None else s["size"]
        alpha = 0.8 if s["alpha"] is None else s["alpha"]
        marker = s["marker"] or "o"
        filled = MarkerStyle(marker).is_filled()
        ax.scatter(x[ok], y[ok], s=size * size, color=col, marker=marker, alpha=alpha,
                   linewidths=0 if filled else 1.0, label=s["label"] or "_nolegend_", zorder=3)
        if s["lo"] is not None:
            lo, hi = np.asarray(s["lo"]), np.asarray(s["hi"])
            eok = ok & np.isfinite(lo) & np.isfinite(hi)
            if eok.any():
                yerr = np.vstack([np.maximum(y[eok] - lo[eok], 0), np.maximum(hi[eok] - y[eok], 0)])
                ax.errorbar(x[eok], y[eok], yerr=yerr, fmt="none", ecolor=col,
                            elinewidth=0.8, alpha=alpha, zorder=2)


def _draw_bar(ax, p, np, colors):
    import matplotlib.patches as mpatches
    cats = p["categories"]
    k = max(1, len(p["series"]))
    group = 0.8
    width = group / k
    base = np.arange(len(cats), dtype=float)
    any_lb = False
    ymax = None
    for i, (s, col) in enumerate(zip(p["series"], colors)):
        xs = base - group / 2 + width * (i + 0.5)
        y = np.asarray(s["y"])
        ok = np.isfinite(y)
        lb = np.asarray(s["lower_bound"], dtype=bool)
        alpha = 0.9 if s["alpha"] is None else s["alpha"]
        label = s["label"] or "_nolegend_"
        for j in np.nonzero(ok)[0]:
            ax.bar(xs[j], y[j], width=width * 0.92, color=col, alpha=alpha,
                   hatch="////" if lb[j] else None, edgecolor="white" if lb[j] else col,
                   linewidth=0.0 if not lb[j] else 0.6, label=label, zorder=3)
            label = "_nolegend_"
        if label != "_nolegend_":  # series with no values at all: still in the legend
            ax.bar([np.nan], [np.nan], color=col, label=label)
        top = y.copy()
        if s["lo"] is not None:
            lo, hi = np.asarray(s["lo"]), np.asarray(s["hi"])
            eok = ok & np.isfinite(lo) & np.isfinite(hi)
            if eok.any():
                yerr = np.vstack([np.maximum(y[eok] - lo[eok], 0), np.maximum(hi[eok] - y[eok], 0)])
                ax.errorbar(xs[eok], y[eok], yerr=yerr, fmt="none", ecolor="#222222",
                            elinewidth=0.8, capsize=2, zorder=4)
                top[eok] = np.maximum(top[eok], hi[eok])
        for j in np.nonzero(ok & lb)[0]:
            any_lb = True
            ax.annotate("≥", (xs[j], top[j]), xytext=(0, 1), textcoords="offset points",
                        ha="center", va="bottom", fontsize=8, fontweight="bold", color="#222222",
                        zorder=5)
        if np.isfinite(top).any():
            m = float(np.nanmax(top))
            ymax = m if ymax is None else max(ymax, m)
    ax.set_xticks(base)
    long_labels = len(cats) > 5 or max(len(cat) for cat in cats) > 9
    ax.set_xticklabels(cats, rotation=30 if long_labels else 0,
                       ha="right" if long_labels else "center",
                       rotation_mode="anchor")
    ax.set_xlim(-0.5, len(cats) - 0.5)
    if any_lb and not p["logy"] and ymax is not None and ymax > 0 and p["ylim"] is None:
        ax.set_ylim(top=ymax * 1.12)  # room for the "≥" marks
    ax.grid(axis="y", alpha=0.3, linewidth=0.6, zorder=0)
    ax.set_axisbelow(True)
    if any_lb:
        return [mpatches.Patch(facecolor="#999999", edgecolor="white", hatch="////",
                               label="≥ lower bound")]
    return []


def _apply_limits(ax, p):
    if p["xlim"] is not None:
        ax.set_xlim(left=p["xlim"][0], right=p["xlim"][1])
    if p["ylim"] is not None:
        ax.set_ylim(bottom=p["ylim"][0], top=p["ylim"][1])


def _draw_diagonal(ax, p):
    x0, x1 = ax.get_xlim()
    y0, y1 = ax.get_ylim()
    lo, hi = min(x0, y0), max(x1, y1)
    if p["logx"] or p["logy"]:
        lo = max(lo, 1e-300)
    ax.plot([lo, hi], [lo, hi], color="#555555", linestyle=":", linewidth=1.0,
            label="y = x", zorder=1)
    if p["xlim"] is None:
        ax.set_xlim(lo, hi)
    if p["ylim"] is None:
        ax.set_ylim(lo, hi)


def _log_tick_labels(ax, p):
    """Log axes over everyday magnitudes get plain labels (1, 10, 100, and
    2, 5, ... when few decades are shown) instead of 10^k."""
    from matplotlib.ticker import LogFormatter

    class Plain(LogFormatter):
        def _num_to_string(self, x, vmin, vmax):
            return f"{x:g}"

    for on, axis, lim in ((p["logx"] and p["kind"] != "bar", ax.xaxis, ax.get_xlim()),
                          (p["logy"], ax.yaxis, ax.get_ylim())):
        if on and 1e-3 <= min(lim) and max(lim) <= 1e5:
            axis.set_major_formatter(Plain())
            axis.set_minor_formatter(Plain(labelOnlyBase=False, minor_thresholds=(2, 0.5)))


def draw_panel(ax, p, np, cycle):
    colors = [s["color"] or cycle[i % len(cycle)] for i, s in enumerate(p["series"])]
    if p["logx"] and p["kind"] != "bar":
        ax.set_xscale("log")
    if p["logy"]:
        ax.set_yscale("log")
    extra = []
    if p["kind"] == "line":
        _draw_line(ax, p, np, colors)
    elif p["kind"] == "scatter":
        _draw_scatter(ax, p, np, colors)
    else:
        extra = _draw_bar(ax, p, np, colors)
    if p["kind"] != "bar":
        ax.grid(alpha=0.3, linewidth=0.6, which="major")
    for h in p["hlines"]:
        ax.axhline(h["y"], linestyle=h["linestyle"], color=h["color"], linewidth=1.0,
                   label=h["label"] or "_nolegend_", zorder=2)
    _apply_limits(ax, p)
    if p["diagonal"]:
        _draw_diagonal(ax, p)
    for a in p["annotations"]:
        ax.annotate(a["text"], (a["x"], a["y"]), xytext=(3, 3), textcoords="offset points",
                    fontsize=7, color="#222222", zorder=6)
    if p["title"]:
        ax.set_title(p["title"])
    if p["xlabel"]:
        ax.set_xlabel(p["xlabel"])
    if p["ylabel"]:
        ax.set_ylabel(p["ylabel"])
    _log_tick_labels(ax, p)
    if p["legend"]:
        handles, labels = ax.get_legend_handles_labels()
        handles += extra
        labels += [h.get_label() for h in extra]
        if handles:
            ax.legend(handles, labels, loc="best", frameon=True, framealpha=0.85,
                      borderpad=0.3, labelspacing=0.25, handlelength=1.6, handletextpad=0.4)


def render(spec, out_path, mpl):
    import numpy as np
    import matplotlib.pyplot as plt

    panels = spec["panels"]
    n = len(panels)
    cols = spec["columns"]
    rows = (n + cols - 1) // cols
    pw, ph = spec["panel_size"]
    fonts = _fonts(n)
    with mpl.rc_context(fonts):
        width = cols * pw
        title_h = (fonts["figure.titlesize"] * 1.6 / 72.0) if spec["title"] else 0.0
        cap_lines = []
        cap_fs = 8
        if spec["caption"]:
            chars = max(20, int((width - 0.8) * 72.0 / (cap_fs * 0.52)))
            for para in spec["caption"].splitlines() or [""]:
                cap_lines += textwrap.wrap(para, chars) or [""]
        cap_h = (len(cap_lines) * cap_fs * 1.35 + 10) / 72.0 if cap_lines else 0.0
        height = rows * ph + title_h + cap_h
        fig, axes = plt.subplots(rows, cols, figsize=(width, height), squeeze=False)
        try:
            cycle = mpl.rcParams["axes.prop_cycle"].by_key()["color"]
            for i, ax in enumerate(axes.flat):
                if i < n:
                    draw_panel(ax, panels[i], np, cycle)
                else:
                    ax.set_visible(False)
            if spec["title"]:
                fig.suptitle(spec["title"], fontweight="bold", y=1.0 - 0.2 * title_h / height,
                             va="top")
            if cap_lines:
                fig.text(0.5 / width, (cap_h - 4 / 72.0) / height, "\n".join(cap_lines),
                         ha="left", va="top", fontsize=cap_fs, color="#333333",
                         linespacing=1.25)
            # tight_layout already keeps clear of the suptitle.
            fig.tight_layout(rect=(0, cap_h / height, 1, 1),
                             pad=0.6, h_pad=0.8, w_pad=0.8)
            _save_atomic(fig, out_path, spec["dpi"])
        finally:
            plt.close(fig)


def _save_atomic(fig, out_path, dpi):
    d = os.path.dirname(os.path.abspath(out_path))
    stem = os.path.basename(out_path)
    fd, tmp = tempfile.mkstemp(prefix="." + stem + ".", suffix=".tmp", dir=d)
    try:
        with os.fdopen(fd, "wb") as f:
            fig.savefig(f, format="png", dpi=dpi, metadata={"Software": None},
                        facecolor="white")
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(tmp, 0o666 & ~umask)
        os.replace(tmp, out_path)
    except BaseException:
        try:
            os.unlink(tmp)
        except OSError:
            pass
        raise


# --------------------------------------------------------------------------
# Command line
# --------------------------------------------------------------------------

def collect(args, err):
    files = []
    for a in args:
        if os.path.isdir(a):
            found = sorted(os.path.join(a, f) for f in os.listdir(a)
                           if f.endswith(".json") and os.path.isfile(os.path.join(a, f)))
            if not found:
                sys.stderr.write(f"{PROG}: {a}: no *.json files\n")
            files += found
        elif os.path.isfile(a):
            files.append(a)
        else:
            err(a, "no such file or directory")
    return files


def main(argv):
    if not argv or argv[0] in ("-h", "--help"):
        sys.stdout.write(__doc__)
        return 0 if argv else 2
    mpl = _import_matplotlib()
    mpl.rcdefaults()  # ignore any matplotlibrc: same spec, same bytes
    failed = False

    def err(path, msg):
        nonlocal failed
        failed = True
        sys.stderr.write(f"{PROG}: {path}: {msg}\n")

    for path in collect(argv, err):
        def warn(msg, path=path):
            sys.stderr.write(f"{PROG}: {path}: warning: {msg}\n")
        try:
            with open(path, encoding="utf-8") as f:
                raw = json.load(f)
        except json.JSONDecodeError as e:
            err(path, f"invalid JSON: {e}")
            continue
        except (OSError, UnicodeDecodeError) as e:
            err(path, f"cannot read: {e}")
            continue
        try:
            spec = check_spec(raw, warn)
        except SpecError as e:
            err(path, str(e))
            continue
        out = os.path.splitext(path)[0] + ".png"
        try:
            render(spec, out, mpl)
        except Exception as e:  # a spec that validated but matplotlib refused
            err(path, f"drawing failed: {type(e).__name__}: {e}")
            continue
        print(out, flush=True)
    return 2 if failed else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
