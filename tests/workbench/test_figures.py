"""matplotlib figures: what they plot against what."""
import matplotlib
import numpy as np
import pytest

from workbench import figures

matplotlib.use("Agg")


def test_convergence_figure_plots_against_step_numbers(tmp_path, monkeypatch):
    """The sweeps and residuals of the recorded steps are drawn at their step numbers
    (records every 10 steps here), not at the record index; a step array of the wrong
    length is refused, naming the field."""
    drawn = {}
    monkeypatch.setattr(figures, "_save", lambda fig, path: drawn.setdefault("fig", fig))
    steps = np.arange(10, 60, 10)
    figures.convergence_figure([5, 40, 300, 20, 7], [1e-5, 2e-5, 9e-5, 3e-5, 1e-6],
                               tmp_path / "c.png", tol=1e-4, max_iter=1000, step=steps)
    top, bottom = drawn["fig"].axes
    np.testing.assert_array_equal(top.lines[0].get_xdata(), steps)
    np.testing.assert_array_equal(bottom.lines[0].get_xdata(), steps)
    assert bottom.get_xlabel() == "step"
    with pytest.raises(ValueError, match="step must have one entry per record"):
        figures.convergence_figure([1, 2], [1e-5, 1e-5], tmp_path / "d.png", step=[10])
