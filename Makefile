# Two entry points for a fresh machine: `make demo` (the main job) and `make test`.
# `make demo` installs steerlab with its runtime only; `make test` adds every extra and the test tools. Both install
# the versions of constraints.txt, the lock of pyproject.toml (`make lock` writes it), with uv.
PYTHON ?= python3
MIN_PYTHON := 3.11# the same as requires-python in pyproject.toml
VENV := .venv
BIN := $(VENV)/bin
UV := $(BIN)/uv
UV_VERSION := 0.13.8
# uv installs without byte-compiling (half the install time); Python writes each module's bytecode when it is first
# imported, also where the environment says PYTHONDONTWRITEBYTECODE.
export PYTHONDONTWRITEBYTECODE =
# uv reads no pip.conf: it is given the index, the extra indexes and the wheel folders pip is configured with (`pip
# config list`; a machine's wheel folder may hold torch's CPU build) and takes the best match across them, as pip
# does; it works for .venv's python and never downloads a Python of its own.
UV_ENV = eval "$$($(BIN)/python -m pip config list | sed -n -e 's/^[^.]*\.index-url=/export UV_DEFAULT_INDEX=/p' \
	-e 's/^[^.]*\.extra-index-url=/export UV_INDEX=/p' -e 's/^[^.]*\.find-links=/export UV_FIND_LINKS=/p')"; \
	export UV=$(UV) UV_PYTHON=$(BIN)/python UV_PYTHON_DOWNLOADS=never UV_INDEX_STRATEGY=unsafe-best-match;
INSTALL = $(UV_ENV) $(UV) pip install --quiet --constraint constraints.txt

.PHONY: install demo test docs check-deps lock bench mutation clean rebuild

# A Python's version ("3.12"), or nothing when it does not run or is older than MIN_PYTHON.
comma := ,
version_of = $(shell $(1) -c 'import sys; print("%d.%d" % sys.version_info[:2] if sys.version_info >= ($(subst .,$(comma),$(MIN_PYTHON)),) else "")' 2>/dev/null)
PYTHON_VERSION = $(call version_of,$(PYTHON))
check_python = $(if $(PYTHON_VERSION),,$(error steerlab needs Python $(MIN_PYTHON) or newer (tested on 3.11, 3.12 and 3.13); PYTHON=$(PYTHON) is $(or $(shell $(PYTHON) -c 'import platform; print("Python", platform.python_version())' 2>/dev/null),not a Python that runs)))

# The .venv is used only as make leaves it. One that make did not finish making, whose last install did not finish
# (.venv/.installing stays from the start of an install to its end, as after Ctrl-C), whose python does not run,
# without uv (made before make installed with uv), or made with another Python than a PYTHON given to make, is made
# anew, with one line saying why.
ifneq ($(wildcard $(VENV)),)
ifeq ($(wildcard $(VENV)/.made),)
WHY := it was not made by make, or its making did not finish
else
VENV_VERSION := $(call version_of,$(BIN)/python)
WHY := $(if $(wildcard $(VENV)/.installing),its last install did not finish,$(if $(VENV_VERSION),,its python does not run))
WHY := $(or $(WHY),$(if $(wildcard $(UV)),,it has no uv))
ifneq ($(origin PYTHON),file)
$(check_python)
WHY := $(or $(WHY),$(if $(filter $(VENV_VERSION),$(PYTHON_VERSION)),,it has Python $(VENV_VERSION), PYTHON=$(PYTHON) is $(PYTHON_VERSION)))
endif
endif
endif
ifneq ($(WHY),)
$(info $(VENV): $(WHY); making it anew)
REBUILD := rebuild
endif

$(VENV)/.made: $(REBUILD)
	$(check_python)
	rm -rf $(VENV)
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet uv==$(UV_VERSION)
	touch $@

# steerlab with $(1) ("." or ".[test]") installed in one uv run, then the modules $(2) and $(3) imported once, the
# two lists side by side (which also writes their bytecode); .venv/.installing marks an install that has not finished.
define install
	touch $(VENV)/.installing
	$(INSTALL) -e '$(1)'
	$(BIN)/python -W ignore -c 'import $(2)' & pid=$$!; $(BIN)/python -W ignore -c 'import $(3)' && wait $$pid
	rm $(VENV)/.installing
endef
# torch and its compiler module (which torch.optim imports) take as long as the rest together. The test set's lists
# hold what the suite imports in several processes at once (its workers, their fork servers, torchrun's ranks), so
# that none of them compiles it again.
RUNTIME := torch, torch._dynamo, matplotlib
RUNTIME_REST := steerlab.cli, cv2, numpy, yaml, tqdm
TESTING := $(RUNTIME), pytest, xdist, torch.distributed.run, torch.nn.parallel, torch.utils.tensorboard, torch.onnx
TESTING_REST := $(RUNTIME_REST), optuna, optuna.storages, optuna.importance, optuna.visualization.matplotlib, \
	sqlalchemy.orm, alembic, pandas, scipy.stats, sklearn, psycopg, onnx, onnxruntime, onnxruntime.quantization, \
	rosbags.highlevel, socketio, eventlet

$(VENV)/.runtime: pyproject.toml constraints.txt $(REBUILD) | $(VENV)/.made
	$(call install,.,$(RUNTIME),$(RUNTIME_REST))
	touch $@

$(VENV)/.test: pyproject.toml constraints.txt $(REBUILD) | $(VENV)/.made  # the test set holds the runtime
	$(call install,.[test],$(TESTING),$(TESTING_REST))
	touch $(VENV)/.runtime $@

install: $(VENV)/.runtime

demo: $(VENV)/.runtime
	$(BIN)/steerlab demo --out runs/demo

test: $(VENV)/.test
	$(BIN)/python -m pytest -q -n 2 --dist worksteal

$(VENV)/.docs: pyproject.toml constraints.txt $(REBUILD) | $(VENV)/.runtime
	$(INSTALL) -e '.[docs]'
	touch $@

# The documentation site in site/ (mkdocs.yml): the README as its front page, then docs/; a broken link fails it.
docs: $(VENV)/.docs
	NO_MKDOCS_2_WARNING=1 $(BIN)/python -m mkdocs build --strict

# That constraints.txt is pyproject.toml's lock, and that the runtime and the test set resolve on every supported
# Python for x86-64 and aarch64 Linux, with pyproject.toml's ranges and with constraints.txt: uv's dry runs from
# wheels only, nothing installed (.ci/deps.sh).
check-deps: $(VENV)/.made
	$(UV_ENV) sh .ci/deps.sh check

# constraints.txt anew, for every Python and platform at once (.ci/deps.sh): the pins already there kept where they
# still fit pyproject.toml, or with UPGRADE=1 the newest versions its ranges allow (torch stays at its pin); then the
# test suite with them. Review the diff and commit it when the suite passed (on 3.12, 3.13: make test PYTHON=...).
lock: $(VENV)/.made
	$(UV_ENV) sh .ci/deps.sh lock $(if $(UPGRADE),--upgrade)
	$(MAKE) test

bench: $(VENV)/.test  # the timings of benchmarks/ (the experiments of studies/ run one by one, some for hours)
	for b in benchmarks/bench_*.py; do $(BIN)/python -m benchmarks.$$(basename $$b .py) || exit 1; done

# Mutation testing (docs/results/mutation.md) of the functions that decide results: lap timing and pace, the mirror
# and augmentations, the throttle's scale, cap and floor, the checkpoint's seal, option ranges, replay's interventions,
# the leaderboard's scoring, the sim's part pilot, the training objective and its epoch's draws, the lane controller
# and the rooms' looks. pyproject.toml's [tool.mutmut] names their files and the tests that exercise them; the
# mutants live in mutants/. Not part of `make test`: hours on two shared cores.
MUTATE := 'steerlab.sim.track.world.x?Laps?*' 'steerlab.sim.track.suite.x_drive_row__*' \
	'steerlab.sim.track.suite.x_summarize__*' 'steerlab.sim.track.suite.x_round_columns__*' \
	'steerlab.train.augment.*' 'steerlab.donkey.x?SteerlabPilot?_throttle__*' 'steerlab.donkey.x__check__*' \
	'steerlab.sim.track.world.x?RacerPilot?step__*' \
	'steerlab.checkpoint.x_save_payload__*' 'steerlab.checkpoint.x__seal_intact__*' \
	'steerlab.checkpoint.x_load_checkpoint__*' \
	'steerlab.options.x?Range?__call____*' 'steerlab.options.x?Range?words__*' 'steerlab.options.x__num__*' \
	'steerlab.sim.replay.world.x?ReplayWorld?observe__*' 'steerlab.sim.replay.world.x?ReplayWorld?leaves_lane__*' \
	'steerlab.sim.replay.world.x?ReplayWorld?intervene__*' 'steerlab.sim.track.replay.x?TrackReplayWorld?overhang__*' \
	'steerlab.sim.track.replay.x?TrackReplayWorld?leaves_lane__*' 'steerlab.sim.core.driving.x_autonomy__*' \
	'steerlab.sim.core.driving.x?Trajectory?interventions__*' 'steerlab.sim.core.driving.x?Trajectory?metrics__*' \
	'steerlab.evaluate.scoring.x_score__*' 'steerlab.evaluate.scoring.x_read_steering_csv__*' \
	'steerlab.evaluate.scoring.x_spread_said__*' 'steerlab.evaluate.metrics.x_mse__*' \
	'steerlab.evaluate.metrics.x_rmse__*' 'steerlab.evaluate.metrics.x_mae__*' 'steerlab.evaluate.metrics.x_mae_deg__*' \
	'steerlab.evaluate.metrics.x_gamma_deg__*' \
	'steerlab.control.x_number__*' 'steerlab.control.x?Throttle?*' 'steerlab.control.x_lane_steering__*' \
	'steerlab.sim.core.part.x?PartPilot?step__*' 'steerlab.train.loop.x__mean_error__*' \
	'steerlab.train.loop.x_objective__*' 'steerlab.train.batches.x_epoch_repeats__*' \
	'steerlab.sim.track.lane.x?LanePilot?step__*' 'steerlab.sim.track.look.*'

mutation: $(VENV)/.test
	$(INSTALL) mutmut==3.8.1
	nice -n 10 $(BIN)/mutmut run --max-children 1 $(MUTATE)
	$(BIN)/mutmut results

clean:
	rm -rf runs .steerlab-cache site .hypothesis mutants
