"""docs/examples/first_figure.py, the worked example of docs/python.md: the page shows the
script as it is, and the script runs (at quick settings) to a figure."""
import os
import re
import subprocess
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
SCRIPT = os.path.join(ROOT, "docs", "examples", "first_figure.py")


def test_the_page_shows_the_script_as_it_is():
    page = open(os.path.join(ROOT, "docs", "python.md")).read()
    blocks = re.findall(r"```python\n(.*?)```", page, re.S)
    assert open(SCRIPT).read() in blocks


def test_the_example_draws_the_figure(tmp_path):
    out = tmp_path / "figure.png"
    r = subprocess.run([sys.executable, SCRIPT, str(out), "glass_caustic", "4", "16", "24"], capture_output=True,
                       text=True, env=dict(os.environ), timeout=300)
    assert r.returncode == 0, r.stderr
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    m = re.search(r"agreement ([0-9.]+), kappa ([-0-9.]+), spearman\(sigma\^2\) ([-0-9.]+)", r.stdout)
    assert m, r.stdout
    agreement, kappa, rho = map(float, m.groups())
    assert 0.0 < agreement <= 1.0 and -1.0 <= kappa <= 1.0 and -1.0 <= rho <= 1.0
