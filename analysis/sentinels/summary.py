#!/usr/bin/python3
"""One CSV row per sentinel evaluation of a folder, for the claims table.

    summary.py DIR [--check]

Reads DIR/<record>/evaluation.json for every DIR/<record>.json and writes
DIR/summary.csv (atomically): the verdict counts, the label agreement and
its margin-curve prediction, the PSNR of uniform, observed-var, bucket-floor
and oracle with observed-var's gap to uniform and bucket-floor's to
observed-var (paired MSE wins), `other`'s energy share, and rho(C, G) with
its interval where the record predicted its sign, and the reference's
pixel shares of diffuse-indirect, delta-mediated and glossy. With DIR/clearcoat_sweep.json
present, the sweep's label change and the ball's mean gamma per value are
written to DIR/clearcoat_sweep.csv as well. --check: exit 1 when a file would
change.
"""
import csv
import io
import json
import os
import re
import sys
import tempfile


def outcome(ev, name):
    for o in ev["outcomes"]:
        if o["name"] == name:
            return o
    return None


def strategy(ev, name):
    for s in ev["strategies"]:
        if s["name"] == name:
            return s
    return None


def wins(a, b):
    return sum(1 for x, y in zip(a["mse"], b["mse"]) if x < y)


def summary_rows(folder):
    rows = []
    for name in sorted(os.listdir(folder)):
        if not name.endswith(".json") or name == "clearcoat_sweep.json":
            continue
        rec = name[:-5]
        path = os.path.join(folder, rec, "evaluation.json")
        if not os.path.exists(path):
            raise SystemExit("summary.py: %s has no evaluation (%s)" % (name, path))
        with open(path) as f:
            ev = json.load(f)
        with open(os.path.join(folder, name)) as f:
            if "taxonomy" in json.load(f):
                raise SystemExit("summary.py: %s labels by a taxonomy's classes: this table reads the buckets' "
                                 "predictions" % name)
        margin = outcome(ev, "reliability.margin")
        if margin is None:
            raise SystemExit("summary.py: %s's evaluation has no reliability.margin (registered without a curve?): "
                             "this table reads it (%s)" % (name, path))
        other = outcome(ev, "coverage.other.energy_share")
        uni, ov, bf, orc = (strategy(ev, s) for s in ("uniform", "observed-var", "bucket-floor", "oracle"))
        rho = outcome(ev, "structure.rho_CG_sign")
        rho_v = rho_lo = rho_hi = ""
        if rho:
            m = re.match(r"([+-]?[0-9.]+) \[([+-]?[0-9.]+), ([+-]?[0-9.]+)\]", rho["measured"])
            if m:
                rho_v, rho_lo, rho_hi = m.groups()
        rows.append({
            "record": rec,
            "pass": ev["summary"]["pass"], "fail": ev["summary"]["fail"],
            "indeterminate": ev["summary"]["indeterminate"],
            "agreement": margin["measured"], "agreement_predicted": margin["predicted"],
            "psnr_uniform": "%.4f" % uni["psnr_mean"], "psnr_observed_var": "%.4f" % ov["psnr_mean"],
            "psnr_bucket_floor": "%.4f" % bf["psnr_mean"], "psnr_oracle": "%.4f" % orc["psnr_mean"],
            "observed_var_minus_uniform_db": "%.4f" % (ov["psnr_mean"] - uni["psnr_mean"]),
            "bucket_floor_minus_observed_var_db": "%.4f" % (bf["psnr_mean"] - ov["psnr_mean"]),
            "bucket_floor_mse_wins_vs_observed_var": "%d/%d" % (wins(bf, ov), len(bf["mse"])),
            "other_energy_share": other["measured"],
            "ref_share_diffuse_indirect": outcome(ev, "coverage.diffuse_indirect.pixel_share")["measured"],
            "ref_share_delta_mediated": outcome(ev, "coverage.delta_mediated.pixel_share")["measured"],
            "ref_share_glossy": outcome(ev, "coverage.glossy.pixel_share")["measured"],
            "rho_cg": rho_v, "rho_cg_lo": rho_lo, "rho_cg_hi": rho_hi,
        })
    return rows


def clearcoat_rows(folder):
    path = os.path.join(folder, "clearcoat_sweep.json")
    if not os.path.exists(path):
        return None
    with open(path) as f:
        sw = json.load(f)
    return [{"render": r["render"], "ball_mean_gamma": "%.6f" % r["ball_mean_gamma"],
             "label_changed_first_to_last": "%.6f" % sw["label_changed_first_to_last"],
             "ball_mean_gamma_monotone_rising": str(sw["ball_mean_gamma_monotone_rising"]).lower()}
            for r in sw["per_render"]]


def as_csv(rows):
    out = io.StringIO()
    w = csv.DictWriter(out, fieldnames=list(rows[0].keys()), lineterminator="\n")
    w.writeheader()
    w.writerows(rows)
    return out.getvalue()


def write_or_check(path, text, check):
    old = open(path).read() if os.path.exists(path) else None
    if check:
        if old != text:
            print("summary.py: %s is stale; run analysis/sentinels/summary.py without --check" % path)
            return 1
        return 0
    fd, tmp = tempfile.mkstemp(dir=os.path.dirname(path) or ".")
    with os.fdopen(fd, "w") as f:
        f.write(text)
    os.replace(tmp, path)
    return 0


def main(argv):
    args = [a for a in argv[1:] if a != "--check"]
    if len(args) != 1:
        print(__doc__, file=sys.stderr)
        return 2
    folder, check = args[0], "--check" in argv
    rc = write_or_check(os.path.join(folder, "summary.csv"), as_csv(summary_rows(folder)), check)
    cc = clearcoat_rows(folder)
    if cc:
        rc |= write_or_check(os.path.join(folder, "clearcoat_sweep.csv"), as_csv(cc), check)
    return rc


if __name__ == "__main__":
    sys.exit(main(sys.argv))
