# Every target installs what it needs into .venv first (python3 -m venv + pip).
PYTHON ?= python3
VENV   := .venv
PY     := $(VENV)/bin/python
STAMP  := $(VENV)/.installed

# System packages (Debian/Ubuntu, installed with apt when missing; see `make sysdeps`):
#  off-screen rendering: EGL + Mesa's llvmpipe software GL (OSMesa as the fallback), used by
#  the VTK wheel when there is no display (workbench/render.py);
#  ParaView's pvpython (tests/workbench/test_paraview.py reads every PVD with it, and runs the
#  exported open_in_paraview.py under xvfb-run: Debian's build renders only with an X server).
APT_RENDER   := libegl1 libegl-mesa0 libgl1-mesa-dri libosmesa6
APT_PARAVIEW := paraview python3-paraview xvfb xauth
#  Chromium for the browser tests of `nscd view` (tests/workbench/test_view.py drives it with
#  Playwright for Python through its executable_path: no browser download at run time).
APT_BROWSER  := chromium

.PHONY: install sysdeps test test-slow demo bench bench-peers clean

$(STAMP): pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip
	$(PY) -m pip install --quiet -e '.[test]'
	touch $(STAMP)

install: $(STAMP) sysdeps

## make sysdeps: apt-get install the system packages above that are missing (sudo if not
## root); a no-op when they are all there; a warning, not an error, without apt or rights.
## A first ParaView install takes about 30 s with a warm apt cache (79 MB download, 108
## packages with --no-install-recommends), a few minutes on a slow mirror.
sysdeps:
	@if ! command -v dpkg-query >/dev/null 2>&1 || ! command -v apt-get >/dev/null 2>&1; then \
	  echo "sysdeps: no dpkg/apt here; install EGL or OSMesa (Mesa), ParaView and Chromium yourself" \
	       "(the ParaView test skips without pvpython)"; exit 0; fi; \
	missing=""; \
	for p in $(APT_RENDER) $(APT_PARAVIEW) $(APT_BROWSER); do \
	  dpkg-query -W -f='$${Status}' $$p 2>/dev/null | grep -q "ok installed" || missing="$$missing $$p"; \
	done; \
	if [ -z "$$missing" ]; then exit 0; fi; \
	if [ "$$(id -u)" = 0 ]; then SUDO=""; \
	elif command -v sudo >/dev/null 2>&1 && sudo -n true 2>/dev/null; then SUDO="sudo -n"; \
	else echo "sysdeps: missing$$missing and no root/sudo: apt-get install them yourself"; exit 0; fi; \
	echo "sysdeps: apt-get install$$missing"; \
	install="$$SUDO env DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends$$missing"; \
	$$install >/dev/null || { $$SUDO apt-get update -qq && $$install >/dev/null; } || \
	  echo "sysdeps: apt-get install failed; rendering, the ParaView test or the browser tests may not work"

## make test: the test suite without its long validation runs, two workers, a few minutes;
## first the engine's kernels compiled side by side into numba's cache (engine/warm.py: on a
## fresh clone about a minute, then a second); prints its wall time
test: $(STAMP) sysdeps
	@start=$$(date +%s); $(PY) -m engine.warm && $(PY) -m pytest -n 2 -q --timeout 900 tests; \
	  rc=$$?; echo "make test: $$(( $$(date +%s) - start )) s"; exit $$rc

## make test-slow: the long validation runs (pytest -m slow: the physics controls, the paper
## report, paper and layered preparations, resumes of killed runs, both viewer modes; about
## 15 min on 2 cores); CI runs it after make test
test-slow: $(STAMP) sysdeps
	@start=$$(date +%s); $(PY) -m engine.warm && $(PY) -m pytest -n 2 -q --timeout 900 -m slow tests; rc=$$?; \
	  echo "make test-slow: $$(( $$(date +%s) - start )) s"; exit $$rc

## make demo: the main job, `nscd demo`: a small TexSol cylinder triaxial test ->
## out/demo/run.h5 (HDF5 history), PNG figures and snapshots, a ParaView series
demo: $(STAMP) sysdeps
	$(PY) -m engine.warm
	$(VENV)/bin/nscd demo --out out/demo

## make bench: every benchmark (about 2 h 30 min on 2 idle cores, 1-2 h of it the two
## paper-scale runs of bench_paper_scale.py); each prints its figures and
## writes its JSON under bench/results/ (bench/README.md says what each one measures)
bench: $(STAMP) sysdeps
	$(PY) bench/bench_core.py
	$(PY) bench/bench_wire.py
	$(PY) bench/bench_chains.py
	$(PY) bench/bench_residual.py
	$(PY) bench/bench_compliance.py
	$(PY) bench/bench_freeze.py
	$(PY) bench/bench_scaling.py
	$(PY) bench/bench_parallel.py
	$(PY) bench/bench_solvers.py
	$(PY) bench/tradeoff.py
	$(PY) bench/bench_prep.py
	$(PY) bench/bench_render.py
	$(PY) bench/bench_experiments.py
	$(PY) bench/bench_sweep.py
	$(PY) bench/bench_stop.py
	$(PY) bench/bench_paper_scale.py --test slope
	$(PY) bench/bench_paper_scale.py --test mould
	$(PY) bench/bench_paper_scale.py --test mould --contact-compliance 0.01

## make bench-peers: the same scenes in Siconos and Yade (installed with apt if missing)
bench-peers: $(STAMP)
	bash bench/peers/run.sh

clean:
	rm -rf $(VENV) out .pytest_cache
