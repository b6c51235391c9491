"""matplotlib figures in words: the wire laws of the legends, the test of the title, the
sand reference run, and what the convergence figure says of the solver's work."""
from types import SimpleNamespace

import matplotlib
import numpy as np
import pytest

from engine import laws
from workbench import figures

matplotlib.use("Agg")


@pytest.fixture
def drawn(monkeypatch):
    """The figures drawn (the PNG is still written)."""
    figs = []
    save = figures._save

    def keep(fig, path, **kw):
        figs.append(fig)
        return save(fig, path, **kw)

    monkeypatch.setattr(figures, "_save", keep)
    return figs


LAWS = [(laws.ElasticWire(stiffness=1.0), "elastic wire, k = 1 N"),
        (laws.ElasticWire(stiffness=0.2, prestrain=0.01), "elastic wire, k = 0.2 N, ε₀ = 1 %"),
        (laws.RigidWire(), "rigid wire"),
        (laws.RigidRod(), "rigid rod"),
        (laws.ElasticRod(stiffness=2.0), "elastic rod, k = 2 N"),
        (laws.ElasticRod(stiffness=10.0, prestrain=-0.05), "elastic rod, k = 10 N, ε₀ = −5 %"),
        (laws.BrittleElasticWire(stiffness=1.0, max_tension=0.005),
         "brittle elastic wire, k = 1 N, T_max = 5 mN"),
        (laws.BrittleElasticWire(stiffness=100.0, max_tension=2.5),
         "brittle elastic wire, k = 100 N, T_max = 2.5 N"),
        (laws.wire_law("elastic", stiffness=1000.0), "elastic wire, k = 1000 N"),
        (None, "sand only")]


@pytest.mark.parametrize("law, words", LAWS,
                         ids=[f"{type(law).__name__}-{i}" for i, (law, _) in enumerate(LAWS)])
def test_law_label_says_the_law_in_words(law, words):
    """Each wire law in words, from the law and from a result's params (the law's repr, as
    the tests write it): the prestrain only when not 0, the breaking tension in a unit for
    reading (mN), no class name nor field name left."""
    assert figures.law_label(law) == words
    params = dict(wire=law is not None, wire_law=repr(law))
    assert figures.law_label(params) == words
    assert figures.law_label(SimpleNamespace(params=params)) == words   # a result
    assert figures.law_label(repr(law)) == words


def test_law_label_of_names_and_words():
    """A name of the WIRE_LAWS table is its default law; words already are kept; params
    that name no wire are refused."""
    assert figures.law_label("elastic") == "elastic wire, k = 1 N"
    assert figures.law_label("rigid_rod") == "rigid rod"
    assert figures.law_label("none") == "sand only"
    assert figures.law_label(dict(wire=False, wire_law="ElasticWire(stiffness=1.0)")) == "sand only"
    assert figures.law_label("elastic k=0.2 N, seed 0") == "elastic k=0.2 N, seed 0"
    with pytest.raises(ValueError, match="name no wire"):
        figures.law_label({"tol": 1e-4})
    assert figures.experiment_title("cylinder_triaxial") == "cylinder triaxial test"


def _run(law, q_peak, *, name="cylinder_triaxial", n=20):
    e = np.linspace(0, 0.05, n)
    q = q_peak * np.tanh(60 * e)
    return SimpleNamespace(name=name, axial_strain=e, deviator=q, volumetric_strain=0.3 * e,
                           wire_equivalent=(0.0 if law is None else 40.0) * np.tanh(30 * e),
                           params=dict(pressure=15e3, wire=law is not None,
                                       wire_law=repr(law)))


def _legend(ax):
    return [t.get_text() for t in ax.get_legend().get_texts()]


def test_stress_strain_legend_in_words_with_the_sand_reference(tmp_path, drawn):
    """The legend names the wire laws in words and the sand reference run (a dark dashed
    line in the deviator and volumetric panels, not in the wire's); the title says the
    test and its confining pressure in words; the deviator reads in kPa."""
    runs = [_run(laws.ElasticWire(stiffness=0.2), 14e3), _run(laws.RigidWire(), 18e3)]
    ref = _run(None, 11e3)
    out = figures.stress_strain_figure(runs, tmp_path / "ss.png", title="cylinder_triaxial",
                                       reference=ref)
    assert out.is_file()
    q, vol, wire = drawn[-1].axes
    assert _legend(q) == ["elastic wire, k = 0.2 N", "rigid wire", "sand only (reference)"]
    assert q.get_title() == "cylinder triaxial test, confining pressure 15 kPa"
    assert q.get_ylabel().endswith("[kPa]")
    for a in (q, vol):
        line = a.lines[-1]
        assert line.get_linestyle() == "--" and line.get_label() == "sand only (reference)"
        assert np.allclose(matplotlib.colors.to_rgb(line.get_color()), 0.2)
    np.testing.assert_allclose(q.lines[-1].get_ydata(), ref.deviator / 1e3)
    assert len(wire.lines) == 2                      # the two wires, no reference


def test_stress_strain_with_a_reference_per_seed(tmp_path, drawn):
    """Fig. 14's layout: the sand runs of each seed as dashed grey references, each with
    its label; a sand run among the results draws nothing in the wire panel; with more
    than four entries the legend sits right of the panels (its box off the axes)."""
    runs = [_run(laws.ElasticWire(stiffness=0.2), 14e3), _run(laws.RigidWire(), 18e3),
            _run(None, 10e3)]
    refs = [_run(None, 11e3), _run(None, 12e3)]
    figures.stress_strain_figure(runs, tmp_path / "f14.png", reference=refs,
                                 labels=["k0.2", "rigid", "sand again"],
                                 reference_label=["sand only, seed 0", "sand only, seed 1"])
    fig = drawn[-1]
    q, vol, wire = fig.axes
    assert _legend(q) == ["k0.2", "rigid", "sand again", "sand only, seed 0",
                          "sand only, seed 1"]
    dashed = [ln for ln in q.lines if ln.get_linestyle() == "--"]
    assert [ln.get_label() for ln in dashed] == ["sand only, seed 0", "sand only, seed 1"]
    assert len({ln.get_color() for ln in dashed}) == 2           # two greys
    np.testing.assert_allclose(dashed[1].get_ydata(), refs[1].deviator / 1e3)
    assert [len(ln.get_xdata()) for ln in wire.lines] == [20, 20, 0]   # no sand line
    fig.canvas.draw()
    box = q.get_legend().get_window_extent()
    assert box.x0 >= q.get_window_extent().x1                    # right of the panel
    with pytest.raises(ValueError, match="reference_label: one per reference run"):
        figures.stress_strain_figure(runs, tmp_path / "x.png", reference=refs,
                                     reference_label=["one"])


def test_stress_strain_default_words_and_labels_as_laws(tmp_path, drawn):
    """Without labels nor title: the laws of the results' params and their test in words;
    labels may be laws (put in words) or words (kept)."""
    figures.stress_strain_figure(_run(laws.ElasticWire(stiffness=1.0, prestrain=0.02), 9e3),
                                 tmp_path / "a.png")
    q = drawn[-1].axes[0]
    assert _legend(q) == ["elastic wire, k = 1 N, ε₀ = 2 %"]
    assert q.get_title() == "cylinder triaxial test, confining pressure 15 kPa"
    figures.stress_strain_figure([_run(None, 9e3), _run(None, 9e3)], tmp_path / "b.png",
                                 labels=[laws.RigidRod(), "sand, seed 1"],
                                 title="Fig. 14: cylinder triaxial")
    q = drawn[-1].axes[0]
    assert _legend(q) == ["rigid rod", "sand, seed 1"]
    assert q.get_title() == "Fig. 14: cylinder triaxial"


def test_convergence_title_counts_the_steps_at_max_iter(tmp_path, drawn):
    """10 recorded steps, 3 at max_iter: the title states them (count and %), the mean and
    max sweeps and the largest residual / tol reached (4); the red markers are those 3
    steps, in the sweeps panel and the residual panel (linear, around the data)."""
    it = np.array([40, 1000, 120, 80, 1000, 60, 30, 1000, 50, 45])
    res = np.full(10, 2.9e-4)
    res[[1, 4, 7]] = [4.5e-4, 1.2e-3, 6e-4]
    steps = np.arange(10, 110, 10)
    figures.convergence_figure(it, res, tmp_path / "c.png", tol=3e-4, max_iter=1000,
                               step=steps, converged=res <= 3e-4)
    sweeps, resid = drawn[-1].axes
    title = sweeps.get_title()
    assert title.splitlines() == [
        "10 recorded steps, 3 at max_iter = 1000 (30 %)",
        "NLGS sweeps per step: mean 342, max 1000; largest residual reached / tol = 4"]
    for a in (sweeps, resid):
        np.testing.assert_array_equal(a.lines[1].get_xdata(), [20, 50, 80])
    np.testing.assert_allclose(resid.lines[1].get_ydata(), [1.5, 4.0, 2.0])
    assert resid.get_yscale() == "linear"
    lo, hi = resid.get_ylim()
    assert lo == 0 and 4.0 < hi < 5.0
    assert "at max_iter (not converged)" in _legend(sweeps)[0]


def test_convergence_all_converged_says_so_in_words(tmp_path, drawn):
    """Every recorded step converged (residual at tol): no flat residual line, the panel
    says it in words; the title says none stopped at max_iter."""
    it = np.array([40, 100, 120, 80, 30, 60, 30, 20, 50, 45])
    res = np.full(10, 2.99e-4)
    figures.convergence_figure(it, res, tmp_path / "c.png", tol=3e-4, max_iter=1000,
                               step=np.arange(10, 110, 10), n_contacts=np.arange(10) + 100,
                               converged=np.ones(10, bool))
    sweeps, resid, contacts = drawn[-1].axes
    assert [t.get_text() for t in resid.texts] == [
        "all 10 recorded steps converged (residual ≤ tol)"]
    assert not resid.lines and not resid.axison
    assert sweeps.get_title().splitlines()[0] == "10 recorded steps, none at max_iter = 1000"
    assert "largest residual reached / tol = 0.997" in sweeps.get_title()
    assert contacts.get_xlabel() == "step" and contacts.get_ylabel() == "contacts"
