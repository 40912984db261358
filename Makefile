# hairshade — the two commands of the README:
#   make run    build, validate the BSDFs against Mitsuba 3, render the demo head with
#               the rasterizer and with Mitsuba (prints tables, times, errors; images in out/)
#   make test   build, then the whole test suite (cargo test, pytest, notebooks, the docs site)
# Everything else (virtual environment, Python packages, the LLVM library
# Mitsuba's JIT variant wants) is installed by the targets below.

PYTHON ?= python3
VENV   ?= .venv
PY     := $(VENV)/bin/python
STAMP  := $(VENV)/.deps-stamp
LLVM19 := /usr/lib/x86_64-linux-gnu/libLLVM-19.so
export VIRTUAL_ENV := $(abspath $(VENV))
export PATH := $(abspath $(VENV))/bin:$(PATH)

.PHONY: run test build llvm bench clean docs wheel

run: build
	$(PY) -m hairshade validate
	$(PY) -m hairshade demo

# cargo test builds the crate without the `python` feature; in maturin's
# target directory that would overwrite the extension's build and make the
# next `make run` (maturin) rebuild it from scratch, so it has its own.
CARGO_TEST_DIR := target/cargo-test

test: build
	CARGO_TARGET_DIR=$(CARGO_TEST_DIR) cargo test --release --all-targets
	$(PY) -m pytest -q tests --nbmake notebooks
	$(MAKE) docs

# The wheel for manylinux2014 (glibc 2.17 and later), built with zig, into
# target/wheels/ (scripts/wheel_check.sh installs and tries it).
wheel: $(STAMP)
	$(PY) -m pip install -q ziglang auditwheel
	mkdir -p $(VENV)/zig && printf '#!/bin/sh\nexec $(abspath $(PY)) -m ziglang "$$@"\n' > $(VENV)/zig/zig && chmod +x $(VENV)/zig/zig
	PATH=$(abspath $(VENV))/zig:$$PATH CARGO_TARGET_DIR=target/zig $(VENV)/bin/maturin build --release --zig \
		--compatibility manylinux2014 -o target/wheels -q

# The documentation site (docs/_build/index.html): topic pages and an API page
# per public name; a warning (a broken reference, a malformed docstring) fails it.
docs: build
	rm -rf docs/_build docs/_generated
	$(VENV)/bin/sphinx-build -E -W --keep-going -q -b html docs docs/_build

$(STAMP): requirements-dev.txt
	test -x $(PY) || $(PYTHON) -m venv $(VENV)
	$(PY) -m pip install -q --upgrade pip
	$(PY) -m pip install -q -r requirements-dev.txt
	touch $(STAMP)

# Mitsuba's llvm_ad_rgb variant needs an LLVM newer than Debian 12's default;
# without it hairshade falls back to scalar_rgb (slower, same results).
llvm:
	@if [ ! -e $(LLVM19) ] && command -v apt-get >/dev/null 2>&1 && [ "$$(id -u)" = 0 ]; then \
		(apt-get install -y -q libllvm19 >/dev/null 2>&1 || (apt-get update -q >/dev/null 2>&1 && apt-get install -y -q libllvm19 >/dev/null 2>&1)) \
		|| echo "note: libllvm19 could not be installed; Mitsuba will use scalar_rgb"; \
	fi

build: $(STAMP) llvm
	$(VENV)/bin/maturin develop --release -q

bench: build
	cargo bench --bench fiber
	$(PY) -m hairshade bench --out docs

clean:
	rm -rf $(VENV) target
