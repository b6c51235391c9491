"""The example gallery and the notebooks run (at a smoke size) without error."""
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
EXAMPLES = sorted(p.name for p in (ROOT / "examples").glob("0*.py") if p.name != "01_deposit.py")
#: The examples and notebooks that take about 10 s or more (run by `make test-slow`).
SLOW = {"03_cylinder_triaxial.py", "04_slope.py", "05_gravity_deposit.py", "explore.ipynb",
        "tour.ipynb"}


def _marked(names):
    return [pytest.param(n, marks=pytest.mark.slow) if n in SLOW else n for n in names]


@pytest.mark.parametrize("name", _marked(EXAMPLES))
def test_example_runs(name, tmp_path):
    r = subprocess.run([sys.executable, str(ROOT / "examples" / name), "--smoke", "--out",
                        str(tmp_path)], capture_output=True, text=True, timeout=600, cwd=ROOT)
    assert r.returncode == 0, r.stderr[-3000:]
    assert "wrote" in r.stdout
    assert any(tmp_path.glob("*.png"))


def test_deposit_example_runs(tmp_path):
    r = subprocess.run([sys.executable, str(ROOT / "examples" / "01_deposit.py"), "--out",
                        str(tmp_path), "--n", "60", "--steps", "200", "--wire-beads", "10",
                        "--radius", "2e-3"], capture_output=True, text=True, timeout=600,
                       cwd=ROOT)
    assert r.returncode == 0, r.stderr[-3000:]
    assert (tmp_path / "deposit.png").exists()


@pytest.mark.parametrize("nb", _marked(sorted(p.name for p in (ROOT / "notebooks").glob("*.ipynb"))))
def test_notebook_executes(nb, tmp_path):
    nbformat = pytest.importorskip("nbformat")
    nbclient = pytest.importorskip("nbclient")
    book = nbformat.read(ROOT / "notebooks" / nb, as_version=4)
    nbclient.NotebookClient(book, timeout=600, kernel_name="python3",
                            resources={"metadata": {"path": str(tmp_path)}}).execute()
    errors = [o for c in book.cells if c.cell_type == "code" for o in c.get("outputs", [])
              if o.get("output_type") == "error"]
    assert not errors


@pytest.mark.slow
def test_the_readmes_higher_up_example_runs(tmp_path):
    """The README's "Higher up" code, as it is printed: a sample built, relaxed in its
    mould, given to the cylinder test, a picture drawn."""
    text = (ROOT / "README.md").read_text()
    block = text.split("Higher up:", 1)[1].split("```python", 1)[1].split("```", 1)[0]
    r = subprocess.run([sys.executable, "-W", "ignore", "-c", block], capture_output=True,
                       text=True, timeout=900, cwd=tmp_path,
                       env={**__import__("os").environ, "PYTHONPATH": str(ROOT)})
    assert r.returncode == 0, r.stderr[-3000:]
    assert (tmp_path / "out" / "wire.png").stat().st_size > 10_000
    assert (tmp_path / "out" / "c.h5").exists() and (tmp_path / "out" / "d.h5").exists()
