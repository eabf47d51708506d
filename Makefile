# Every target creates the local virtual environment first (fresh machine: Python 3.11 + pip).
PY ?= python3
VENV := .venv
STAMP := $(VENV)/.installed-stamp
OUT ?= hdrfringe-demo

.PHONY: install system-packages demo test test-narrow lint bench bench-sweep bench-cold bench-peers \
	bench-memory bench-measure bench-measure-stereo bench-unwrap bench-large bench-acceptance native \
	clean

# The projector window tests (tests/test_projector_window.py) run a real X server: Xvfb, with
# Mesa's OpenGL (GLX, software rendering) and the X client libraries pyglet loads. Installed with
# apt-get (as root, or through sudo) only when Xvfb or Mesa's GLX is missing.
X_PACKAGES := xvfb libgl1 libglx-mesa0 libgl1-mesa-dri libx11-6 libxext6 libxi6 libxinerama1 \
	libxrandr2 libxrender1 libxxf86vm1
# The report test (tests/test_report_browser.py) opens report.html in headless Chromium: Debian's
# package, installed the same way when /usr/bin/chromium is missing.
BROWSER_PACKAGES := chromium
SUDO := $(shell [ "$$(id -u)" = 0 ] || echo sudo)

NATIVE_SRC := $(wildcard src/hdrfringe/core/_native/*.c)

# The editable install compiles the native kernels in place (setup.py); a changed C file
# reinstalls. With it the research package (research/: `hdrfringe reproduce`, dask, xarray, zarr),
# which the product does not need; its command joins `hdrfringe` through an entry point.
# pip installs uv into the environment and uv installs the rest: the same packages and versions
# as pip (the lower bounds in pyproject.toml), resolved and unpacked in parallel, about 20 s on a
# fresh machine instead of about 70 s (both measured on this project, 2 cores), and the install
# counts against the test run's 10 minutes. --compile-bytecode: uv, unlike pip, leaves the
# packages' bytecode to be written at first import, and where PYTHONDONTWRITEBYTECODE is set
# (this machine sets it) it is never written, so every new interpreter compiled numpy, scipy and
# matplotlib again: `import hdrfringe.cli._app, numpy, scipy.ndimage, matplotlib.pyplot` took
# 2.0-2.3 s instead of 0.8 s, in every test that starts a process (measured on a clean clone).
$(STAMP): pyproject.toml setup.py $(NATIVE_SRC) research/pyproject.toml
	$(PY) -m venv $(VENV)
	$(VENV)/bin/pip install --quiet --disable-pip-version-check "uv>=0.5"
	$(VENV)/bin/uv pip install --quiet --python $(VENV)/bin/python --compile-bytecode \
		-e ".[dev]" -e research
	touch $(STAMP)

system-packages:
	@if ! command -v Xvfb >/dev/null 2>&1 || ! ls /usr/lib*/libGLX_mesa.so.0 /usr/lib*/*/libGLX_mesa.so.0 2>/dev/null | grep -q .; then \
		echo "installing Xvfb and Mesa OpenGL for the projector window tests: $(X_PACKAGES)"; \
		$(SUDO) apt-get update -qq && \
		$(SUDO) env DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends \
			$(X_PACKAGES); \
	fi
	@if ! command -v chromium >/dev/null 2>&1; then \
		echo "installing Chromium for the report's browser test: $(BROWSER_PACKAGES)"; \
		$(SUDO) apt-get update -qq && \
		$(SUDO) env DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends \
			$(BROWSER_PACKAGES); \
	fi

install: $(STAMP) system-packages

# Rebuild the native kernels in place after editing src/hdrfringe/core/_native/*.c (a worktree run
# with PYTHONPATH=src uses them from there).
native: $(STAMP)
	$(VENV)/bin/python setup.py -q build_ext --inplace

demo: $(STAMP)
	$(VENV)/bin/hdrfringe demo -o $(OUT) --force

# Both test trees: the product's (pyproject's testpaths) and the research package's.
TEST_PATHS := tests src/hdrfringe README.md research/tests research/src

# The project's own modules (editable installs: not compiled by the install) compiled once
# before the tests, for the same reason (about 0.4 s; stale files are recompiled by mtime).
test: $(STAMP) system-packages
	$(VENV)/bin/ruff check src tests benchmarks research
	$(VENV)/bin/python -m compileall -q src research/src > /dev/null
	$(VENV)/bin/pytest -n 2 --dist loadgroup -q -m "not quick_reproduction" \
		$(foreach t,$(NARROW_ONLY),--ignore=$(t)) $(TEST_PATHS)
	$(MAKE) --no-print-directory test-narrow

# The numeric tests again as if on another CPU (tests/narrow_cpu.py): numpy's SIMD dispatch
# narrowed to its baseline, OpenBLAS's AVX2 kernels on an AVX-512 machine, the numpy paths
# instead of the native kernels. An expectation tied to one CPU fails here before it fails on a
# user's machine. The modules: decoding, unwrapping, calibration, stereo, strategies, the
# uncertainty model, every docstring example, and the reproduction. The reproduction's tests
# (marker quick_reproduction: they share one 90 s quick sweep) run here only, not in `test`'s
# first run: their reference was made with the full dispatch, so comparing across CPUs is the
# stronger check, and one sweep keeps `make test` short; they come first, so that
# one worker starts the 90 s sweep while the other takes the rest. So do the strategy,
# adaptive-projection, LPA-study and stereo-calibration modules (NARROW_ONLY, about 140 s of
# test time): pure numpy on simulated captures, their decoding covered on the full dispatch and
# the native kernels by every other module. The narrowed run's length is its sweep's (both
# cores, 130 s): the other worker's tests fill the time the sweep leaves free, where in the
# first run they added to its length. The real-data tests (marker realdata) run in the first run only: they are integration
# tests of the same numerics on large images. The reproduction's tests and docstrings are the
# research package's (research/tests, research/src).
NARROW_ONLY := tests/test_strategies.py tests/test_stereo_calibration.py tests/test_adaptive.py \
	tests/test_lpa_study.py
NARROW_TESTS := research/tests/test_quick_grid_identity.py research/tests/test_reproduce.py \
	research/tests/test_reproduce_adaptive.py research/tests/test_reproduce_broken.py \
	research/tests/test_error_budget.py research/src/hdrfringe_thesis \
	src/hdrfringe tests/test_phase.py tests/test_phase_blocks.py \
	tests/test_unwrap.py tests/test_unwrap_paths.py tests/test_graycode.py \
	tests/test_calibration.py tests/test_stereo.py tests/test_stereo_calibration.py \
	tests/test_adaptive.py tests/test_lpa_study.py \
	tests/test_strategies.py tests/test_tolerant.py tests/test_uncertainty.py \
	tests/test_equations.py

test-narrow: $(STAMP)
	env $$($(VENV)/bin/python tests/narrow_cpu.py) $(VENV)/bin/pytest -n 2 --dist loadgroup -q \
		-p no:cacheprovider -m "not realdata" $(NARROW_TESTS)

lint: $(STAMP)
	$(VENV)/bin/ruff check src tests benchmarks research

bench: $(STAMP)
	$(VENV)/bin/python benchmarks/bench_phase.py

# The sweep engine's timing, with the research package that has it.
bench-sweep: $(STAMP)
	$(VENV)/bin/python research/studies/bench_sweep.py

bench-cold: $(STAMP)
	$(VENV)/bin/python benchmarks/bench_cold_start.py

# The peers (fringes, OpenCV contrib) live in their own environment, never in .venv: fringes
# brings numba and opencv-contrib-python, whose cv2 would replace the headless build.
BENCH_VENV := .venv-bench
$(BENCH_VENV)/.installed-stamp: pyproject.toml
	$(PY) -m venv $(BENCH_VENV)
	$(BENCH_VENV)/bin/pip install --quiet -e ".[bench]"
	touch $@

bench-peers: $(BENCH_VENV)/.installed-stamp
	$(BENCH_VENV)/bin/python benchmarks/bench_peers.py

bench-memory: $(BENCH_VENV)/.installed-stamp
	$(BENCH_VENV)/bin/python benchmarks/bench_memory.py

bench-measure: $(STAMP)
	$(VENV)/bin/python benchmarks/bench_measure.py

bench-measure-stereo: $(STAMP)
	$(VENV)/bin/python benchmarks/bench_measure_stereo.py

# The acceptance test's full procedure (23 positions, 640 x 480) and the glossy sphere's HDR table
# (docs/acceptance.md, "The acceptance command"); ACC_OUT keeps the result folders.
ACC_OUT ?= hdrfringe-acceptance
bench-acceptance: $(STAMP)
	$(VENV)/bin/python benchmarks/bench_acceptance.py -o $(ACC_OUT) --force

bench-unwrap: $(STAMP)
	$(VENV)/bin/python benchmarks/bench_unwrap.py

# Renders 648x494, 4096x3000 and 5120x5120 capture folders once (BENCH_CACHE keeps them for
# the next run; about 2 minutes and 0.5 GB the first time) and runs `phase` against a plain
# numpy script on each; `phase` at 5120x5120 peaks at about 1.5 GB (5.4 GB before issue 30).
BENCH_CACHE ?=
bench-large: $(STAMP)
	$(VENV)/bin/python benchmarks/bench_large.py $(if $(BENCH_CACHE),--cache $(BENCH_CACHE))

clean:
	rm -rf $(VENV) $(BENCH_VENV) $(OUT)
