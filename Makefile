# Two entry points for a fresh machine: `make demo` (the main job) and `make test`.
PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed
# Packages are installed without byte-compiling (half the install time); Python writes each module's bytecode
# when it is first imported, also where the environment says PYTHONDONTWRITEBYTECODE.
export PYTHONDONTWRITEBYTECODE =

.PHONY: install demo test bench clean

$(STAMP): pyproject.toml requirements.txt
	test -x $(BIN)/python || $(PYTHON) -m venv $(VENV)
	$(BIN)/pip install --quiet --upgrade pip
	$(BIN)/pip install --quiet --no-compile -r requirements.txt
	$(BIN)/pip install --quiet --no-deps -e .
	touch $(STAMP)

install: $(STAMP)

demo: $(STAMP)
	$(BIN)/steerlab demo --out runs/demo

test: $(STAMP)
	$(BIN)/python -m pytest -q -n 2 --dist worksteal

bench: $(STAMP)  # bench_donkeycar.py is left out: it installs donkeycar and trains for about an hour
	for b in benchmarks/bench_*.py; do case $$b in *donkeycar*) continue;; esac; $(BIN)/python $$b || exit 1; done

clean:
	rm -rf runs .steerlab-cache
