"""analysis/claims/claims_table.py against the committed docs/results (no C++ module needed)."""
import csv
import json
import os
import shutil
import subprocess
import sys

import pytest

ROOT = os.path.normpath(os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", ".."))
SCRIPT = os.path.join(ROOT, "analysis", "claims", "claims_table.py")
CLAIMS = os.path.join(ROOT, "analysis", "claims", "claims.json")
RESULTS = os.path.join(ROOT, "docs", "results")
sys.path.insert(0, os.path.dirname(SCRIPT))
import claims_table  # noqa: E402


def run(*args):
    return subprocess.run([sys.executable, SCRIPT, *args], capture_output=True, text=True)


def verdicts(results):
    claims = claims_table.load_claims(CLAIMS)
    rows = claims_table.evaluate(claims, claims_table.Tables(results))
    return {c["id"]: verdict for c, _, verdict, _ in rows}


def test_committed_readme_is_current():
    r = run("--check")
    assert r.returncode == 0, r.stdout + r.stderr


@pytest.fixture
def results_copy(tmp_path):
    dst = tmp_path / "results"
    shutil.copytree(os.path.join(RESULTS, "tables"), dst / "tables")
    # The allocation study's own tables (the strict criterion and the budget sweep at every pilot).
    shutil.copytree(os.path.join(RESULTS, "allocation", "tables"), dst / "allocation" / "tables")
    shutil.copy(os.path.join(RESULTS, "README.md"), dst / "README.md")
    # The sentinel claims read ../sentinels/**/summary.csv beside the results folder.
    for rel in ("summary.csv", "paper-set/summary.csv", "paper-set/clearcoat_sweep.csv"):
        (tmp_path / "sentinels" / rel).parent.mkdir(parents=True, exist_ok=True)
        shutil.copy(os.path.join(ROOT, "docs", "sentinels", rel), tmp_path / "sentinels" / rel)
    return dst


def test_changed_cell_fails_check_and_flips_verdict(results_copy):
    before = verdicts(str(results_copy))
    assert before["abs-coverage"] == "holds"
    path = results_copy / "tables" / "coverage.csv"
    with open(path, newline="") as f:
        rows = list(csv.reader(f))
    col = rows[0].index("other energy share")
    rows[1][col] = "0.01"
    with open(path, "w", newline="") as f:
        csv.writer(f).writerows(rows)
    after = verdicts(str(results_copy))
    assert after["abs-coverage"] == "differs"
    r = run("--check", "--results", str(results_copy))
    assert r.returncode == 1
    assert "abs-coverage" not in r.stderr  # a stale table, not a malformed claim
    added = [l for l in r.stdout.splitlines() if l.startswith("+|") and "receives no energy" in l]
    assert added and "| differs |" in added[0], r.stdout


def test_missing_column_names_the_claim(tmp_path):
    with open(CLAIMS) as f:
        data = json.load(f)
    target = next(c for c in data["claims"] if c["id"] == "abs-agreement")
    target["measure"]["column"] = "no such column"
    bad = tmp_path / "claims.json"
    bad.write_text(json.dumps(data))
    r = run("--print", "--claims", str(bad))
    assert r.returncode == 2
    assert "abs-agreement" in r.stderr and "no such column" in r.stderr
    assert "cross_spp.csv" in r.stderr


def test_missing_table_and_row_name_the_claim(tmp_path):
    with open(CLAIMS) as f:
        data = json.load(f)
    c = next(c for c in data["claims"] if c["id"] == "s4.3-glass-agree")
    c["measure"]["rows"] = ["no_such_scene"]
    bad = tmp_path / "claims.json"
    bad.write_text(json.dumps(data))
    r = run("--print", "--claims", str(bad))
    assert r.returncode == 2 and "s4.3-glass-agree" in r.stderr and "no_such_scene" in r.stderr


def test_every_claim_is_measured_or_says_why():
    with open(CLAIMS) as f:
        claims = json.load(f)["claims"]
    ids = [c["id"] for c in claims]
    assert len(ids) == len(set(ids))
    for c in claims:
        for k in ("id", "where", "claim", "paper", "why_differs"):
            assert isinstance(c.get(k), str) and c[k].strip(), (c.get("id"), k)
        if c.get("measured", True) is False:
            assert c.get("why", "").strip(), c["id"]
            assert "measure" not in c and "rule" not in c, c["id"]
        else:
            assert "measure" in c and "rule" in c, c["id"]
    claims_table.validate(claims)


def test_validate_rejects_duplicates_and_bare_unmeasured():
    base = {"where": "w", "claim": "c", "paper": "p", "why_differs": "open", "measured": False, "why": "x"}
    with pytest.raises(claims_table.ClaimError, match="duplicate"):
        claims_table.validate([dict(base, id="a"), dict(base, id="a")])
    with pytest.raises(claims_table.ClaimError, match="without a why"):
        claims_table.validate([dict(base, id="a", why="")])
    with pytest.raises(claims_table.ClaimError, match="measure and a rule"):
        claims_table.validate([{k: v for k, v in base.items() if k not in ("measured", "why")} | {"id": "b"}])
