# Every target installs what it needs into .venv first (python3 -m venv + pip).
PYTHON ?= python3
VENV   := .venv
PY     := $(VENV)/bin/python
STAMP  := $(VENV)/.installed

.PHONY: install test demo bench bench-peers clean

$(STAMP): pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip
	$(PY) -m pip install --quiet -e '.[test]'
	touch $(STAMP)

install: $(STAMP)

## make test: the test suite (numba compilation included), two workers
test: $(STAMP)
	$(PY) -m pytest -n 2 -q tests

## make demo: the main job (gravity deposit; figures + ParaView series under out/demo)
demo: $(STAMP)
	$(PY) examples/01_deposit.py --out out/demo

## make bench: benchmarks; print figures and write JSON under bench/results/
bench: $(STAMP)
	$(PY) bench/bench_core.py
	$(PY) bench/bench_wire.py

## make bench-peers: the same scenes in Siconos and Yade (installed with apt if missing)
bench-peers: $(STAMP)
	bash bench/peers/run.sh

clean:
	rm -rf $(VENV) out .pytest_cache
