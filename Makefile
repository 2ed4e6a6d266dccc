# frictionrt: `make demo` and `make test` each create .venv if missing, install, and run.
PY ?= python3
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed

.PHONY: demo test test-slow bench clean foxglove check-targets

$(BIN)/python:
	$(PY) -m venv $(VENV)

# the install ends by compiling the run-time kernels into numba's cache (frictionrt/warm.py, ~2.5 min on two
# cores, as a C extension compiles at its install), so the first `make demo` runs as fast as the next
$(STAMP): $(BIN)/python pyproject.toml
	$(BIN)/pip install --quiet --upgrade pip
	$(BIN)/pip install --quiet -e '.[test]'
	-$(BIN)/python -m frictionrt.warm --jobs 2
	touch $(STAMP)

demo: $(STAMP)
	$(BIN)/frictionrt modes
	$(BIN)/frictionrt impulse --fn1 100 -o logs/impulse_fn1_100.png --force
	$(BIN)/frictionrt compare --mode 3 --amp 5 --duration 1 -o logs/compare_laws.png --force
	$(BIN)/frictionrt reproduce --quick --out logs/reproduce_quick --force

# the kernels compiled once, on two processes (frictionrt/warm.py, a few seconds where the install or an earlier
# run compiled them: two workers that start together would each compile them in full; a path that fails is
# reported and the suite still runs), then two workers for the suite (its 25 slowest tests listed, for the budget), then
# the timing tests alone (pyproject.toml, marker `timing`)
test: $(STAMP)
	-$(BIN)/python -m frictionrt.warm --jobs 2
	$(BIN)/python -m pytest -q -n 2 --dist worksteal -m "not timing and not slow" --durations=25
	$(BIN)/python -m pytest -q -m timing

# the whole diagnoses and reproductions the suite covers by cheaper twins (marker `slow`; their last single
# durations add to ~40 worker-minutes, so ~20 min or more on 2 cores; not timed as a whole)
test-slow: $(STAMP)
	$(BIN)/python -m pytest -q -n 2 --dist worksteal -m slow

# Foxglove's own decoder for tests/test_log_formats.py (Node.js and npm; the test is skipped without it)
foxglove:
	cd tools/foxglove && npm ci --no-audit --no-fund

# the C export on other targets (docs/export-c.md): installs the cross compilers and qemu-user
# (Debian/Ubuntu; needs root and the network, so it stays out of `make test`), then runs the
# export's target tests: clang, aarch64 under qemu-aarch64, a Cortex-M7 build, the PREEMPT_RT example
TARGET_PACKAGES = clang gcc-aarch64-linux-gnu qemu-user gcc-arm-none-eabi libnewlib-arm-none-eabi
check-targets: $(STAMP)
	apt-get install -y --no-install-recommends $(TARGET_PACKAGES)
	$(BIN)/python -m pytest -q -p no:xdist tests/test_export_c.py -k "golden or guard or refuses_a_build or preempt or aarch64 or cortex or clang"
	$(BIN)/python -m pytest -q -p no:xdist tests/test_export_float32.py

bench: $(STAMP)
	$(BIN)/python benchmarks/plant.py

clean:
	rm -rf $(VENV) .pytest_cache "$${XDG_CACHE_HOME:-$$HOME/.cache}/frictionrt"
