# Two commands do all set-up on a fresh machine: `make demo` and `make test`.
PYTHON ?= python3
VENV   := .venv
PY     := $(VENV)/bin/python
STAMP  := $(VENV)/.installed

.PHONY: demo test test-other-cpu lint bench bench-open3d clean lcmtypes

$(STAMP): pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip
	$(PY) -m pip install --quiet -e '.[viz,test,dev]'
	touch $(STAMP)

demo: $(STAMP)
	$(VENV)/bin/stereo-terrain demo --out demo_out

# The suite on the machine's cores (at most four workers), a test file to a worker: its
# module fixtures (rendered scenes, pipeline runs) computed once.
PYTEST := $(PY) -m pytest -q -n auto --maxprocesses 4 --dist loadfile

test: $(STAMP)
	$(PYTEST)

# The suite on another CPU's rounding: NumPy, OpenBLAS, OpenCV and Numba held to their
# baseline kernels (no AVX, AVX2, FMA or AVX-512). A single-scene test passes, or skips
# saying which premise its scene no longer sets up (tests/rounding.py).
OTHER_CPU := NPY_DISABLE_CPU_FEATURES="X86_V3 X86_V4 AVX512_ICL AVX512_SPR" \
	OPENBLAS_CORETYPE=Nehalem OPENCV_CPU_DISABLE=AVX,AVX2,FMA3 \
	NUMBA_CPU_NAME=generic NUMBA_CACHE_DIR=$(CURDIR)/$(VENV)/numba-other-cpu

test-other-cpu: $(STAMP)
	$(OTHER_CPU) $(PYTEST) -p no:cacheprovider $(PYTEST_ARGS)

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
