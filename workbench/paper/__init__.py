"""``nscd paper``: reproduce the paper's Fig. 7 (§2.4) and §3 (Fig. 8-16, Table 2) and write a
report.

::

    from workbench.paper import build_report
    report = build_report("out/paper", scale="tiny")       # or "default", "paper"
    report.path          # out/paper/report.md

Every simulation is one case of a :func:`workbench.campaign.sweep` (Dask: a LocalCluster of
two workers, or ``scheduler=`` an address, or "serial"), so a re-run skips the cases already
done (``out/paper/sweep.json``).  Each case writes its HDF5 history (``runs/<name>.h5``) and
the curves the figures need (``runs/<name>.curves.h5``).  The report then draws the
figures (``figures/*.png``), renders snapshots (PyVista), exports four ParaView series
(``series/<name>/*.pvd``) and compares each claim of the paper with our numbers.

Each claim gets a verdict:

* **reproduced** — our numbers satisfy the claim's criterion (stated in the report);
* **not reproduced** — they do not (or the effect is within the spread of the seeds);
* **not comparable** — the numbers cannot decide (too few seeds, no linear range found, a
  failed run), or the scale is the smoke scale ``tiny``, where every claim is marked not
  comparable and the criterion's outcome is shown only as an indication.

Scales (:data:`SCALES`): ``tiny`` (a smoke test, a few minutes on two cores), ``default``
(reduced samples, about 16 minutes on two cores), ``paper`` (the paper's sample sizes: 42
minutes on two cores for Fig. 11-16, about 8 hours more for the 9 slope runs of Fig. 8-10,
and the 3 deposits in the mould of Fig. 7, not timed yet; ``only=`` takes some claims
alone, ``--scheduler`` a cluster).

The package, bottom to top:

* ``scales``: the paper's numbers (:data:`PAPER_VALUES`) and the sizes of a report
  (:class:`Scale`, :data:`SCALES`);
* ``cases``: the runs, by name, and their parameters (``catalogue``);
* ``runner``: one run on a worker (:func:`paper_case`) and its curves file
  (:func:`read_curves`);
* ``stats``: the seeds' statistics, the heaps' slopes, the macro-stiffness H (:func:`h_fit`);
* ``scoring``: the scoring of each claim (``score_figN``, and the ``_figN`` helpers on the
  runs of several seeds), one ``Verdict`` per verdict row;
* ``plots``: the matplotlib figures, one function each;
* ``registry``: **the claim registry** ``CLAIMS``: one ``PaperClaim`` per figure of the
  paper (id "fig14", its verdict rows with their ids, texts, criteria and the runs each
  reads at a scale, its scoring, its figures and pictures, its ParaView series), and the
  loops over it: :func:`claim_runs`, :func:`select_claims`, :func:`cases_for`,
  :func:`evaluate`, ``figures_of``, ``series_runs``;
* ``drawing``: the figures, pictures and series of the chosen claims;
* ``report``: :func:`build_report` and the markdown.

A claim is added or changed in ``registry`` (with its scoring and plot): the runs a report
makes, its verdicts, its figures and its sections follow from ``CLAIMS``.
"""
from __future__ import annotations

from .cases import catalogue
from .drawing import make_figures, series, snapshots
from .registry import (CLAIMS, Claim, PaperClaim, Picture, Plot, Row, cases_for, claim_runs,
                       claims_of, evaluate, figures_of, select_claims, series_runs)
from .report import Report, build_report
from .runner import paper_case, read_curves
from .scales import (COMMON_FIT_DEGREE, PAPER_FIT_DEGREE, PAPER_VALUES, R_MIN_BOX, SCALES, Scale,
                     fig10_seeds, scale_named)
from .scoring import Verdict
from .stats import H_FIT_FROM, h_fit, heap_slopes

# the names of the single module this package was (tests and scripts import them from here)
from .plots import _empty, _res  # noqa: F401
from .registry import FIG10_NOTE  # noqa: F401
from .report import (_git_commit, _markdown, _rel, _run_lines, _run_names,  # noqa: F401
                     _table2_lines)
from .runner import _law, _outer_radius_profile, _write_curves  # noqa: F401
from .scales import _fmt_k  # noqa: F401
from .scoring import _fig7, _fig10, _fig11, _fig12, _fig13c  # noqa: F401
from .stats import (_against, _g, _H_list, _H_of, _seed_stats, _significant,  # noqa: F401
                    _spearman, _verdict)

__all__ = ["SCALES", "Scale", "PAPER_VALUES", "PAPER_FIT_DEGREE", "COMMON_FIT_DEGREE",
           "R_MIN_BOX", "H_FIT_FROM", "scale_named", "fig10_seeds", "catalogue",
           "CLAIMS", "PaperClaim", "Row", "Plot", "Picture", "Claim", "Verdict",
           "claim_runs", "select_claims", "claims_of", "cases_for", "figures_of", "series_runs",
           "evaluate",
           "paper_case", "read_curves", "h_fit", "heap_slopes",
           "make_figures", "snapshots", "series", "build_report", "Report"]
