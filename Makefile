# BladeRecon: install what is missing, test, demo, benchmark.
# FreeCAD's Python modules load only in the Python they were built for: Debian's /usr/bin/python3.
PYTHON ?= /usr/bin/python3
DEB_PACKAGES := freecad python3-numpy python3-scipy python3-matplotlib python3-serial python3-pytest xvfb
SUDO := $(shell [ "$$(id -u)" -eq 0 ] || echo sudo)
export PYTHONPATH := $(CURDIR)$(if $(PYTHONPATH),:$(PYTHONPATH))
export QTWEBENGINE_DISABLE_SANDBOX := 1

.PHONY: all deps test demo bench help

all: test

help:
	@echo "make deps   install the missing Debian packages ($(DEB_PACKAGES))"
	@echo "make test   run the test suite with $(PYTHON)"
	@echo "make demo   reconstruct the sample blade into demo_out/"
	@echo "make bench  run the benchmarks (bench/run_all.py)"

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

# pytest's exit 5 (no test collected) is not a failure of the tree.
test: deps
	@$(PYTHON) -m pytest -q tests; rc=$$?; [ $$rc -eq 5 ] && rc=0; exit $$rc

demo: deps
	@mkdir -p demo_out
	$(PYTHON) -m bladerecon reconstruct resources/sample/measured.csv -o demo_out/blade.step --nominal resources/sample/nominal.step --report demo_out/report --json

bench: deps
	$(PYTHON) bench/run_all.py
