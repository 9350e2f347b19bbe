#!/usr/bin/python3
"""The paper's claims, one by one, against the study's committed tables.

Reads analysis/claims/claims.json (one entry per quantitative claim of the
paper's abstract, contributions and §4-§8) and the CSV tables of a results
directory (default docs/results), computes vkmech's value for every measured
claim and decides holds / differs with the claim's own rule, and writes a
Markdown table between the markers

    <!-- claims:begin -->
    <!-- claims:end -->

of docs/results/README.md (written to a temporary file, then renamed).

    claims_table.py                  rewrite the README's table
    claims_table.py --check          exit 1 with a diff if the README differs
    claims_table.py --print          print the table, touch nothing

Options: --results DIR, --claims FILE, --readme FILE.
Exit status: 0 fine, 1 --check found a difference, 2 a claim or table is
malformed (the message names the claim and the file/row/column).

Measures (JSON, see claims.json):
  {"file": "tables/x.csv", "key": "scene", "rows": ["a", "b"],
   "where": {"N0": "4"}, "column": "col"}            one value per row
  {..., "vars": {"a": "col", "b": {"column": "c", "where": {...},
   "file": "...", "parse": "hi"}}, "expr": "a - b"}    a value per row
  {"file": "tables/transitions_{row}.csv", "matrix": {...}} (see _matrix)
  a list of such blocks: their values are concatenated.
A row is a key value (string) or {"label": "...", "where": {...}}.
"""
import argparse
import csv
import difflib
import json
import math
import os
import sys
import tempfile

BEGIN = "<!-- claims:begin -->"
END = "<!-- claims:end -->"
HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.normpath(os.path.join(HERE, "..", ".."))
MISSING = {"---", "deg.", "n/a", ""}
ABBREV = {"cubes_dof": "cb", "glass_caustic": "gc", "snooker": "sn",
          "tabletop_mixed": "tm", "tabletop_separated": "ts",
          "ring_caustic": "rc", "kitchen_counter": "kc"}
DEFAULT_REL = 0.10


class ClaimError(Exception):
    pass


def parse_cell(text):
    """A CSV cell as a number where it is one: '7/10' -> 7, '---' -> None."""
    t = text.strip()
    if t in MISSING:
        return None
    try:
        return float(t)
    except ValueError:
        pass
    if "/" in t:
        a, _, b = t.partition("/")
        try:
            return float(int(a))
        except ValueError:
            pass
    return t


def parse_hi(text):
    """'3.02-3.32' (a seed-std range) -> 3.32."""
    if isinstance(text, float):
        return text
    parts = [p for p in str(text).replace("–", "-").split("-") if p]
    return max(float(p) for p in parts)


class Tables:
    def __init__(self, results):
        self.results = results
        self.cache = {}

    def load(self, cid, name):
        if name not in self.cache:
            path = os.path.join(self.results, name)
            if not os.path.isfile(path):
                raise ClaimError(f"claim {cid}: table {name} not found in {self.results}")
            with open(path, newline="") as f:
                rows = list(csv.reader(f))
            if not rows:
                raise ClaimError(f"claim {cid}: table {name} is empty")
            self.cache[name] = (rows[0], rows[1:])
        return self.cache[name]

    @staticmethod
    def col_index(cid, name, header, col):
        """'error#2' is the second column named 'error'; a bare repeated name is an error."""
        base, _, k = col.rpartition("#") if "#" in col else (col, "", "")
        at = [i for i, h in enumerate(header) if h == base]
        if not at:
            raise ClaimError(f"claim {cid}: {name}: no column '{base}' "
                             f"(columns: {', '.join(header)})")
        if k:
            if not k.isdigit() or not 1 <= int(k) <= len(at):
                raise ClaimError(f"claim {cid}: {name}: no column '{col}'")
            return at[int(k) - 1]
        if len(at) > 1:
            raise ClaimError(f"claim {cid}: {name}: column '{base}' appears {len(at)} times; "
                             f"name one as '{base}#1'..'{base}#{len(at)}'")
        return at[0]

    def cell(self, cid, name, where, column):
        header, rows = self.load(cid, name)
        idx = {c: self.col_index(cid, name, header, c) for c in list(where) + [column]}
        hits = [r for r in rows
                if all(r[idx[c]].strip() == str(v) for c, v in where.items())]
        if len(hits) != 1:
            sel = ", ".join(f"{c}={v}" for c, v in where.items())
            what = "no row" if not hits else f"{len(hits)} rows"
            raise ClaimError(f"claim {cid}: {name}: {what} with {sel}")
        return hits[0][idx[column]]

    def matrix(self, cid, name, spec):
        """Operations on a square transition table (first column: from)."""
        header, rows = self.load(cid, name)
        labels = header[1:]
        m = {}
        for r in rows:
            for j, lab in enumerate(labels):
                m[(r[0].strip(), lab)] = float(r[j + 1])
        op = spec["op"]
        if op == "offdiag_sum":
            return sum(v for (a, b), v in m.items() if a != b)
        if op == "total":
            return sum(m.values())
        if op == "pairs_sum":
            for a, b in spec["pairs"]:
                if (a, b) not in m:
                    raise ClaimError(f"claim {cid}: {name}: no cell {a} -> {b}")
            return sum(m[(a, b)] for a, b in spec["pairs"])
        if op == "max_offdiag_touching":
            touch = set(spec["buckets"])
            return max(v for (a, b), v in m.items() if a != b and (a in touch or b in touch))
        raise ClaimError(f"claim {cid}: {name}: unknown matrix op '{op}'")


def _rows(block):
    out = []
    for r in block.get("rows", [None]):
        if isinstance(r, dict):
            out.append((r.get("label", ""), r["where"], r.get("fmt_row", None)))
        elif r is None:
            out.append(("", {}, None))
        else:
            out.append((r, {block["key"]: r} if block.get("key") else {}, r))
    return out


def _eval(cid, expr, names):
    env = {"abs": abs, "max": max, "min": min, "__builtins__": {}}
    env.update(names)
    try:
        return eval(expr, env)  # noqa: S307 - the project's own claims.json
    except Exception as e:  # pragma: no cover - message path
        raise ClaimError(f"claim {cid}: expression '{expr}' failed: {e}")


def measure_block(cid, tables, block):
    values = []
    base_where = block.get("where", {})
    if block.get("rows") == "*":
        header, rows = tables.load(cid, block["file"])
        i = Tables.col_index(cid, block["file"], header, block["column"])
        if not rows:
            raise ClaimError(f"claim {cid}: {block['file']}: no rows")
        return [(" ".join(r[:2]), parse_cell(r[i]), block) for r in rows]
    for label, row_where, row_name in _rows(block):
        def fname(spec_file):
            f = spec_file or block.get("file")
            if not f:
                raise ClaimError(f"claim {cid}: measure names no file")
            return f.replace("{row}", row_name or "")

        def get(spec):
            if isinstance(spec, str):
                spec = {"column": spec}
            f = fname(spec.get("file"))
            if "matrix" in spec:
                return tables.matrix(cid, f, spec["matrix"])
            where = dict(base_where)
            where.update(row_where)
            where.update(spec.get("where", {}))
            raw = tables.cell(cid, f, where, spec["column"])
            v = parse_cell(raw)
            if spec.get("parse") == "hi" and v is not None:
                v = parse_hi(raw)
            return v

        if "vars" in block:
            names = {k: get(s) for k, s in block["vars"].items()}
            if any(v is None for v in names.values()):
                v = None
            else:
                v = _eval(cid, block["expr"], names)
        elif "matrix" in block:
            v = get({"matrix": block["matrix"]})
        elif "column" in block:
            v = get(block["column"])
        else:
            raise ClaimError(f"claim {cid}: measure has neither column, vars nor matrix")
        lab = block.get("label", "{row}").replace("{row}", ABBREV.get(label, label))
        values.append((lab.strip(), v, block))
    return values


def measure(cid, tables, spec):
    blocks = spec if isinstance(spec, list) else [spec]
    out = []
    for b in blocks:
        out.extend(measure_block(cid, tables, b))
    return out


def _num(v):
    return isinstance(v, (int, float)) and not isinstance(v, bool)


def _rounded(v, rule):
    d = rule.get("decimals")
    return round(v, d) if d is not None and _num(v) else v


def _cond(v, op, x):
    if not _num(v):
        return False
    return {"<": v < x, "<=": v <= x, ">": v > x, ">=": v >= x,
            "==": v == x, "!=": v != x}[op]


def apply_rule(cid, rule, values):
    """Returns (holds, list of labels that break the rule)."""
    t = rule["type"]
    vals = [(lab, v) for lab, v, _ in values]
    if t == "range":
        lo = -math.inf if rule.get("lo") is None else rule["lo"]
        hi = math.inf if rule.get("hi") is None else rule["hi"]
        bad = [lab for lab, v in vals
               if not _num(v) or not (lo <= _rounded(v, rule) <= hi)]
        return not bad, bad
    if t == "approx":
        targets = rule["target"]
        if not isinstance(targets, list):
            targets = [targets] * len(vals)
        if len(targets) != len(vals):
            raise ClaimError(f"claim {cid}: {len(targets)} targets for {len(vals)} values")
        rel = rule.get("rel", DEFAULT_REL)
        bad = [lab for (lab, v), x in zip(vals, targets)
               if not _num(v) or abs(v - x) > max(rel * abs(x), rule.get("abs", 0.0)) + 1e-12]
        return not bad, bad
    if t == "signs":
        exp = rule["signs"]
        if len(exp) != len(vals):
            raise ClaimError(f"claim {cid}: {len(exp)} signs for {len(vals)} values")
        bad = [lab for (lab, v), s in zip(vals, exp)
               if not _num(v) or not ((v > 0) if s == "+" else (v < 0))]
        return not bad, bad
    if t == "count":
        op, x = rule["cond"]
        met = [lab for lab, v in vals if _cond(v, op, x)]
        nop, n = rule["need"]
        ok = _cond(float(len(met)), nop, n)
        return ok, ([] if ok else [lab for lab, v in vals if lab not in met])
    if t == "equal":
        bad = [lab for lab, v in vals if v != rule["value"]]
        return not bad, bad
    if t in ("decreasing", "increasing", "not_monotone"):
        xs = [v for _, v in vals]
        if not all(_num(v) for v in xs):
            return False, [lab for lab, v in vals if not _num(v)]
        dec = all(a > b for a, b in zip(xs, xs[1:]))
        inc = all(a < b for a, b in zip(xs, xs[1:]))
        nondec = all(a <= b for a, b in zip(xs, xs[1:]))
        noninc = all(a >= b for a, b in zip(xs, xs[1:]))
        ok = {"decreasing": dec, "increasing": inc,
              "not_monotone": not (nondec or noninc)}[t]
        return ok, []
    if t in ("argmin", "argmax"):
        good = [(lab, v) for lab, v in vals if _num(v)]
        if not good:
            return False, []
        pick = (min if t == "argmin" else max)(good, key=lambda p: p[1])[0]
        return pick == rule["label"], ([] if pick == rule["label"] else [pick])
    if t == "set":
        op, x = rule["cond"]
        met = sorted(lab for lab, v in vals if _cond(v, op, x))
        exp = sorted(rule["labels"])
        return met == exp, sorted(set(met) ^ set(exp))
    if t == "spread":
        xs = [v for _, v in vals]
        if not all(_num(v) for v in xs):
            return False, []
        mean = sum(xs) / len(xs)
        return (max(xs) - min(xs)) <= rule["rel"] * abs(mean), []
    raise ClaimError(f"claim {cid}: unknown rule type '{t}'")


def fmt_value(v, block):
    if v is None:
        return "---"
    if not _num(v):
        return str(v)
    spec = block.get("fmt", "{:.3g}")
    return spec.format(v * block.get("scale", 1))


def describe(values, bad, rule):
    if rule["type"] == "count":
        op, x = rule["cond"]
        met = [(lab, v, b) for lab, v, b in values if _cond(v, op, x)]
        shown = met if any(b.get("show") == "range" for _, _, b in values) else values
        listed = ", ".join(f"{lab} {fmt_value(v, b)}".strip() for lab, v, b in shown)
        return f"{len(met)} of {len(values)}" + (f" ({listed})" if listed else "")
    if any(b.get("show") == "range" for _, _, b in values):
        nums = [v for _, v, _ in values if _num(v)]
        b0 = values[0][2]
        text = (f"{fmt_value(min(nums), b0)} to {fmt_value(max(nums), b0)} over {len(values)}"
                if nums else f"no value over {len(values)}")
        if bad:
            text += "; off: " + ", ".join(
                f"{lab} {fmt_value(v, b)}" for lab, v, b in values if lab in bad)
        return text
    parts = []
    for lab, v, block in values:
        s = fmt_value(v, block)
        if lab:
            s = f"{lab} {s}"
        if lab and lab in bad:
            s = f"**{s}**"
        parts.append(s)
    return ", ".join(parts)


def evaluate(claims, tables):
    rows = []
    for c in claims:
        if c.get("measured", True) is False:
            rows.append((c, "not measured", "not measured", c["why"]))
            continue
        values = measure(c["id"], tables, c["measure"])
        ok, bad = apply_rule(c["id"], c["rule"], values)
        text = describe(values, bad, c["rule"])
        if c.get("note"):
            text += f" ({c['note']})"
        verdict = "holds" if ok else "differs"
        why = "" if ok else c["why_differs"]
        rows.append((c, text, verdict, why))
    return rows


def esc(s):
    return str(s).replace("|", "\\|").replace("\n", " ")


def render(rows):
    n = len(rows)
    counts = {k: sum(1 for r in rows if r[2] == k) for k in ("holds", "differs", "not measured")}
    lines = [f"{n} claims: {counts['holds']} hold, {counts['differs']} differ, "
             f"{counts['not measured']} not measured.", "",
             "| # | where | claim | paper | vkmech | verdict | why |",
             "|---:|:---|:---|:---|:---|:---|:---|"]
    for i, (c, text, verdict, why) in enumerate(rows, 1):
        lines.append(f"| {i} | {esc(c['where'])} | {esc(c['claim'])} | {esc(c['paper'])} "
                     f"| {esc(text)} | {verdict} | {esc(why)} |")
    return "\n".join(lines) + "\n"


def load_claims(path):
    with open(path) as f:
        data = json.load(f)
    claims = data["claims"] if isinstance(data, dict) else data
    validate(claims)
    return claims


def validate(claims):
    seen = set()
    for c in claims:
        cid = c.get("id")
        if not cid:
            raise ClaimError("a claim without an id")
        if cid in seen:
            raise ClaimError(f"claim {cid}: duplicate id")
        seen.add(cid)
        for k in ("where", "claim", "paper", "why_differs"):
            if not isinstance(c.get(k), str) or not c[k].strip():
                raise ClaimError(f"claim {cid}: missing '{k}'")
        if c.get("measured", True) is False:
            if not c.get("why", "").strip():
                raise ClaimError(f"claim {cid}: measured false without a why")
            if "measure" in c or "rule" in c:
                raise ClaimError(f"claim {cid}: measured false but has a measure or rule")
        elif "measure" not in c or "rule" not in c:
            raise ClaimError(f"claim {cid}: needs a measure and a rule, or measured: false")


def splice(readme_text, table, readme_path):
    if BEGIN not in readme_text or END not in readme_text:
        raise ClaimError(f"{readme_path}: markers {BEGIN} / {END} not found")
    head, rest = readme_text.split(BEGIN, 1)
    _, tail = rest.split(END, 1)
    return head + BEGIN + "\n" + table + END + tail


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--results", default=os.path.join(ROOT, "docs", "results"))
    ap.add_argument("--claims", default=os.path.join(HERE, "claims.json"))
    ap.add_argument("--readme", default=None,
                    help="default: README.md of the results directory")
    ap.add_argument("--check", action="store_true")
    ap.add_argument("--print", dest="print_only", action="store_true")
    a = ap.parse_args(argv)
    readme = a.readme or os.path.join(a.results, "README.md")
    try:
        claims = load_claims(a.claims)
        table = render(evaluate(claims, Tables(a.results)))
        if a.print_only:
            sys.stdout.write(table)
            return 0
        with open(readme) as f:
            old = f.read()
        new = splice(old, table, readme)
    except ClaimError as e:
        print(f"claims_table: {e}", file=sys.stderr)
        return 2
    if a.check:
        if new == old:
            return 0
        sys.stdout.writelines(difflib.unified_diff(
            old.splitlines(True), new.splitlines(True), readme, readme + " (regenerated)"))
        print(f"claims_table: {readme} is not what {os.path.relpath(__file__, ROOT)} "
              "writes; run it without --check", file=sys.stderr)
        return 1
    if new != old:
        d = os.path.dirname(os.path.abspath(readme))
        fd, tmp = tempfile.mkstemp(dir=d, prefix=".README.", suffix=".tmp")
        with os.fdopen(fd, "w") as f:
            f.write(new)
        os.chmod(tmp, os.stat(readme).st_mode & 0o777)
        os.replace(tmp, readme)
    return 0


if __name__ == "__main__":
    sys.exit(main())
