# SPDX-License-Identifier: LGPL-2.1-or-later
# BladeRecon: install what is missing, test, demo, benchmark.
# FreeCAD's Python modules load only in the Python they were built for: Debian's /usr/bin/python3.
PYTHON ?= /usr/bin/python3
DEB_PACKAGES := freecad python3-numpy python3-scipy python3-matplotlib python3-serial python3-pytest python3-pytest-xdist python3-hypothesis python3-dask python3-distributed xvfb xauth
SUDO := $(shell [ "$$(id -u)" -eq 0 ] || echo sudo)
export PYTHONPATH := $(CURDIR)$(if $(PYTHONPATH),:$(PYTHONPATH))
export QTWEBENGINE_DISABLE_SANDBOX := 1

.PHONY: all deps test test-freecad1 demo bench help mutation

all: test

help:
	@echo "make deps   install the missing Debian packages ($(DEB_PACKAGES))"
	@echo "make test   run the test suite with $(PYTHON), one worker per core (PYTEST_WORKERS=N, 0: one process)"
	@echo "make test-freecad1   the same suite on FreeCAD 1.0 in a Debian 13 root (.cache/debian13, root only)"
	@echo "make demo   reconstruct the sample blade into demo_out/"
	@echo "make bench  run the benchmarks (bench/run_all.py)"
	@echo "make mutation   mutmut over bladerecon/core module by module (hours; bench/results/mutation.md)"
	@echo "make install   put the bladerecon command on PATH (~/.local/bin, root: /usr/local/bin; PREFIX=DIR)"

# Only packages that are not installed trigger apt-get (messages go to stderr: stdout stays for --json).
deps:
	@missing=""; \
	for pkg in $(DEB_PACKAGES); do \
	  dpkg -s $$pkg 2>/dev/null | grep -q '^Status: install ok installed' || missing="$$missing $$pkg"; \
	done; \
	if [ -n "$$missing" ]; then \
	  echo "deps: installing$$missing" >&2; \
	  $(SUDO) apt-get update >&2 && \
	  $(SUDO) env DEBIAN_FRONTEND=noninteractive apt-get install -y $$missing >&2; \
	else \
	  echo "deps: all Debian packages present" >&2; \
	fi

# pytest's exit 5 (no test collected) is not a failure of the tree. The files are spread over
# one worker per core (pytest-xdist, a file's tests kept together: their module fixtures are built
# once); PYTEST_WORKERS=N sets the count, 0 runs them in this one process.
PYTEST_WORKERS ?= auto
test: deps
	@par=""; if [ "$(PYTEST_WORKERS)" != 0 ] && $(PYTHON) -c "import xdist" 2>/dev/null; then \
	  par="-n $(PYTEST_WORKERS) --dist loadfile"; fi; \
	$(PYTHON) -m pytest -q -rs $$par tests; rc=$$?; [ $$rc -eq 5 ] && rc=0; exit $$rc

# The whole suite on FreeCAD 1.0 (Debian 13, Python 3.13, numpy 2) in a root made once with
# debootstrap into .cache/debian13/; "skipped" (exit 0) where the machine cannot make one.
test-freecad1:
	@bash tools/test_freecad1.sh

# stdout: the JSON summary only (progress goes to stderr), so `make demo | python3 -m json.tool` works.
demo: deps
	@mkdir -p demo_out
	@$(PYTHON) -m bladerecon reconstruct resources/sample/measured.csv -o demo_out/blade.step --nominal resources/sample/nominal.step --report demo_out/report --force --json

# run_all.py: reconstruction against FreeCAD's ways; each bench/bench_*.py: one topic's table
# beside its peers (writes bench/results/<topic>.md).
# Timed as a user's Python runs the code: bytecode compiled once and read from __pycache__ (a shell
# that exports PYTHONDONTWRITEBYTECODE would time recompiling every module on every run, ~0.1-0.3 s
# a process, which no user's second run pays).
bench: deps
	@env -u PYTHONDONTWRITEBYTECODE $(PYTHON) -m compileall -q bladerecon bench >/dev/null
	env -u PYTHONDONTWRITEBYTECODE $(PYTHON) bench/run_all.py
	@for b in bench/bench_*.py; do [ -e "$$b" ] || continue; echo "== $$b"; env -u PYTHONDONTWRITEBYTECODE $(PYTHON) "$$b" || exit $$?; done

# Mutation testing (a development tool from PyPI in .cache/mutation-venv, never a dependency):
# mutmut in a throw-away clone of HEAD; MUTATION_MODULES=alignment,fitting for a subset. Not in CI.
mutation:
	$(PYTHON) tools/mutation.py

# Live acquisition demo: the simulated controller on a pty (paced like 115200 baud, with faults
# and two disconnects), captured by `acquire`, then reconstructed.
.PHONY: demo-acquire
demo-acquire: deps
	@mkdir -p demo_out && rm -f demo_out/ttyBLADE demo_out/acquired.journal
	@$(PYTHON) -m bladerecon simulate-instrument --link demo_out/ttyBLADE --points 400 --bad-checksum 0.01 \
	  --garbled 0.005 --out-of-range 0.01 --disconnects 2 --drop-block 10 --seed 1 > demo_out/simulator.json & \
	for i in $$(seq 100); do [ -L demo_out/ttyBLADE ] && break; sleep 0.1; done; \
	$(PYTHON) -m bladerecon acquire --port demo_out/ttyBLADE -o demo_out/acquired.csv \
	  --journal demo_out/acquired.journal --json && wait && \
	$(PYTHON) -m bladerecon reconstruct demo_out/acquired.csv --quiet --json

# The `bladerecon` command on PATH: a symlink to tools/bladerecon of this checkout, which runs
# the package with /usr/bin/python3 (or BLADERECON_PYTHON) from any directory.
# Root: /usr/local/bin; a user: ~/.local/bin; PREFIX=DIR puts it in DIR/bin.
PREFIX ?= $(if $(filter 0,$(shell id -u)),/usr/local,$(HOME)/.local)
.PHONY: install
install:
	@mkdir -p "$(PREFIX)/bin" && ln -sfn "$(CURDIR)/tools/bladerecon" "$(PREFIX)/bin/bladerecon"
	@echo "install: $(PREFIX)/bin/bladerecon -> $(CURDIR)/tools/bladerecon"
	@case ":$$PATH:" in *":$(PREFIX)/bin:"*) ;; \
	  *) echo "install: $(PREFIX)/bin is not on your PATH: add it (e.g. in ~/.profile: export PATH=\"$(PREFIX)/bin:\$$PATH\")";; esac
