"""matplotlib figures: what they plot against what."""
import matplotlib
import numpy as np
import pytest

from workbench import figures

matplotlib.use("Agg")


def test_convergence_figure_plots_against_step_numbers(tmp_path, monkeypatch):
    """The sweeps and residuals of the recorded steps are drawn at their step numbers
    (records every 10 steps here), not at the record index; a step array of the wrong
    length is refused, naming the field.  (One step stops at max_iter: with every step
    converged the residual panel is words, no curve.)"""
    drawn = {}
    monkeypatch.setattr(figures, "_save", lambda fig, path: drawn.setdefault("fig", fig))
    steps = np.arange(10, 60, 10)
    figures.convergence_figure([5, 40, 1000, 20, 7], [1e-5, 2e-5, 9e-4, 3e-5, 1e-6],
                               tmp_path / "c.png", tol=1e-4, max_iter=1000, step=steps)
    top, bottom = drawn["fig"].axes
    np.testing.assert_array_equal(top.lines[0].get_xdata(), steps)
    np.testing.assert_array_equal(bottom.lines[0].get_xdata(), steps)
    assert bottom.get_xlabel() == "step"
    with pytest.raises(ValueError, match="step must have one entry per record"):
        figures.convergence_figure([1, 2], [1e-5, 1e-5], tmp_path / "d.png", step=[10])


def test_convergence_figure_marks_the_steps_that_did_not_converge(tmp_path, monkeypatch):
    """The history's converged flags pick the red markers, in the three panels (sweeps,
    residual over tol, contacts); the title counts them."""
    drawn = {}
    monkeypatch.setattr(figures, "_save", lambda fig, path: drawn.setdefault("fig", fig))
    steps = np.arange(10, 60, 10)
    figures.convergence_figure([5, 1000, 300, 1000, 7], [1e-5, 5e-4, 9e-5, 2e-4, 1e-6],
                               tmp_path / "c.png", tol=1e-4, max_iter=1000, step=steps,
                               n_contacts=[10, 12, 15, 15, 16], converged=[1, 0, 1, 0, 1])
    axes = drawn["fig"].axes
    assert len(axes) == 3 and axes[2].get_ylabel() == "contacts"
    for a in axes:
        red = a.lines[1]                      # the not-converged markers
        np.testing.assert_array_equal(red.get_xdata(), [20, 40])
    np.testing.assert_allclose(axes[1].lines[1].get_ydata(), [5.0, 2.0])   # residual / tol
    assert axes[0].get_title().startswith("5 recorded steps, 2 at max_iter = 1000 (40 %)")
