# Two commands do all set-up on a fresh machine: `make demo` and `make test`.
PYTHON ?= python3
VENV   := .venv
PY     := $(VENV)/bin/python
STAMP  := $(VENV)/.installed

.PHONY: demo test lint bench bench-open3d clean lcmtypes

$(STAMP): pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip
	$(PY) -m pip install --quiet -e '.[viz,test,dev]'
	touch $(STAMP)

demo: $(STAMP)
	$(VENV)/bin/stereo-terrain demo --out demo_out

test: $(STAMP)
	$(PY) -m pytest -q

lint: $(STAMP)
	$(VENV)/bin/ruff check src tests benchmarks
	$(VENV)/bin/mypy src

bench: $(STAMP)
	$(PY) benchmarks/bench_pipeline.py

# Open3D only in its own environment, never a dependency of the package.
O3D_VENV := benchmarks/.venv-open3d

$(O3D_VENV)/.installed: pyproject.toml
	$(PYTHON) -m venv $(O3D_VENV)
	$(O3D_VENV)/bin/python -m pip install --quiet --upgrade pip
	$(O3D_VENV)/bin/python -m pip install --quiet open3d libusb-package -e .
	touch $(O3D_VENV)/.installed

bench-open3d: $(O3D_VENV)/.installed
	$(O3D_VENV)/bin/python benchmarks/bench_open3d.py

clean:
	rm -rf $(VENV) demo_out .pytest_cache

# Python code of the LCM types (committed); needs lcm-gen from the `lcm` pip package.
LCMDIR := src/stereo_terrain/runtime/lcmtypes
lcmtypes: $(STAMP)
	$(PY) -m pip install --quiet 'lcm>=1.5'
	rm -rf $(LCMDIR)/stereo_terrain_lcm
	$(VENV)/bin/lcm-gen -p --ppath $(LCMDIR) $(LCMDIR)/terrain_t.lcm
