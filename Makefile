# Two entry points: `make report` and `make test` (lint: ruff and mypy; then pytest). Both
# build .venv on first use: `make test` with the test extra, `make report` with the engines'.
PYTHON ?= $(shell command -v python3.11 || command -v python3)
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed
REPORT_STAMP := $(VENV)/.installed-engines
TUNE_STAMP := $(VENV)/.installed-tune
FILES := $(VENV)/.files
# A new folder for every report: evaluated once, so both steps below use the same one.
ifndef OUT
OUT := reports/output/$(shell date +%Y%m%d-%H%M%S)
endif
PACKAGE_FILES := $(sort $(wildcard about/*.py models/*.py reference/*.py engines/*.py \
	engines/*/*.py engines/*/*.toml reports/*.py reports/*/*.py reports/compare/suites/*.toml))

.PHONY: test report releases tune searches findings docs lint format clean bench FORCE

# The strict editable install is a tree of links, one per file, installed as `hoopbench.*`:
# type checkers resolve it, and `import models` stays an error. A new or removed file needs a
# reinstall, so the list of package files is kept here and rewritten only when it changes.
$(FILES): FORCE
	@mkdir -p $(VENV)
	@echo "$(PACKAGE_FILES)" | cmp -s - $@ || echo "$(PACKAGE_FILES)" > $@

$(STAMP): pyproject.toml $(FILES)
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -e ".[test]" --config-settings editable_mode=strict
	touch $(STAMP)

# `make report` needs the engines, not the test tools: the `engines` extra (a venv with the
# test extra has them already, and keeps its tools).
$(REPORT_STAMP): pyproject.toml $(FILES)
	test -x $(BIN)/python || $(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -e ".[engines]" --config-settings editable_mode=strict
	touch $(REPORT_STAMP)

# `make tune` needs Optuna too: the engines' extra and the tune one.
$(TUNE_STAMP): pyproject.toml $(FILES)
	test -x $(BIN)/python || $(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -e ".[engines,tune]" --config-settings editable_mode=strict
	touch $(TUNE_STAMP)

# pytest on every core, a test module to a process (its module fixtures made once): on the
# project's 2 cores the suite took 15 min so, 27 min in one process. PYTEST_ARGS= runs it in one.
PYTEST_ARGS ?= -n auto --dist loadfile

test: lint
	$(BIN)/python -m pytest $(PYTEST_ARGS)

# The shipped searches of `hoopbench tune` (compact: tune.json, front.csv, trials.csv and
# settings.toml of each, no runs), one folder per engine: the report's Best settings section.
SEARCHES ?= reports/tune/searches
SEARCH_DIRS = $(patsubst %/tune.json,%,$(sort $(wildcard $(SEARCHES)/*/tune.json)))
SEARCH_FILES := tune.json front.csv trials.csv settings.toml

# A small hop map (docs/map.md): where each engine's verdict departs from the exact one
# across the lam-chi plane, the one figure that shows where engines fail between the suites'
# named scenes. The default 10 x 10 grid of the three engines that step it cheapest per point
# (MuJoCo, PyBullet, pymunk at 1e-4 s; MJX and Newton, in `hoopbench map`'s default list,
# would add about 90 s on a CPU): its cost is in the README. MAP_ARGS= with no value leaves
# the map out; MAP_ARGS="--grid 40x40" draws a finer one (about 10 minutes).
MAP_ARGS ?= --grid 10x10 --engines mujoco pybullet pymunk

# The default suite, the scenes its timesteps cannot resolve at a finer one (finer.toml),
# the stiff and extreme scenes and the small hop map; then one report of them all and the
# shipped searches. `hoopbench report-runs` runs the suites and the map in one process, each
# into its own folder as `hoopbench compare` and `hoopbench map` would, overlapping on one
# pool of workers (a step begins once the one before has nothing left queued): it says which
# step starts (suite k of 3, the map), and each progress line ends with the overall one (step
# k of 4 and the steps running beside it, runs done of all, an ETA for the whole of make
# report from the runs' expected costs). Then (--report) the same process writes the report
# of them, the searches and the bench, as `hoopbench report --results` would; its drawing
# processes start while the map's last runs end. The report's lines say what it draws.
# REPORT_RUNS_ARGS="--calls FILE" also writes each call's cost (docs/cli.md: the priors).
REPORT_RUNS_ARGS ?=
report: $(REPORT_STAMP)
	$(BIN)/hoopbench report-runs --out $(OUT) --map="$(MAP_ARGS)" $(REPORT_RUNS_ARGS) \
		--report $(SEARCH_DIRS) $(or $(wildcard $(BENCH_OUT)),$(BENCH_SHIPPED))

# The catalogue on several releases of MuJoCo and pymunk (reports/compare/suites/releases.toml),
# each installed once from the package index into $(XDG_CACHE_HOME)/hoopbench/engines (17-65
# MB and 3-10 s of pip a release), and its report: the "Across engine releases" section.
releases: $(REPORT_STAMP)
	$(BIN)/hoopbench compare --suite releases --out $(OUT)/releases
	$(BIN)/hoopbench report --results $(OUT)/releases --out $(OUT)/releases-report

# A search of each engine's settings (docs/tune.md), into $(OUT)/tune/<engine>: each may
# start trials for TUNE_TIMEOUT s (a started trial finishes) up to TUNE_TRIALS, then runs its
# Pareto set on TUNE_HELDOUT held-out scenes per regime: 5-10 minutes an engine on 2 cores.
# The batched engines (mjx, mjwarp, newton) take minutes a trial on a CPU: add them by hand.
TUNE_ENGINES ?= pymunk mujoco pybullet rapier box2d drake dart
TUNE_TRIALS ?= 40
TUNE_TIMEOUT ?= 240
TUNE_HELDOUT ?= 1
tune: $(TUNE_STAMP)
	for engine in $(TUNE_ENGINES); do \
		$(BIN)/hoopbench tune --engine $$engine --out $(OUT)/tune/$$engine \
			--trials $(TUNE_TRIALS) --timeout $(TUNE_TIMEOUT) \
			--heldout-per-regime $(TUNE_HELDOUT) || exit $$?; \
	done
	@echo "searches in $(OUT)/tune; ship them to the report: make searches TUNE=$(OUT)/tune"

# The compact copy of every finished search under TUNE (a folder of `make tune`) into
# $(SEARCHES)/<engine>/, which `make report` reads; an engine already there is not replaced.
searches:
	@test -n "$(TUNE)" || { echo "which searches? make searches TUNE=reports/output/<date>/tune"; exit 2; }
	@for dir in $(TUNE)/*/; do \
		engine=$$(basename $$dir); \
		test -f $$dir/front.csv || { echo "$$dir: no front.csv (resume the search first)"; exit 2; }; \
		test ! -e $(SEARCHES)/$$engine || { echo "$(SEARCHES)/$$engine exists: remove it first"; exit 2; }; \
	done
	@for dir in $(TUNE)/*/; do \
		engine=$$(basename $$dir); \
		mkdir -p $(SEARCHES)/$$engine && \
		for name in $(SEARCH_FILES); do cp $$dir/$$name $(SEARCHES)/$$engine/ || exit $$?; done; \
		echo "$(SEARCHES)/$$engine"; \
	done

# The README's answer, findings and animation from the newest report folder (or RESULTS=...).
RESULTS ?= $(lastword $(sort $(wildcard reports/output/*/default)))
findings: $(REPORT_STAMP)
	@test -n "$(RESULTS)" || { echo "no report yet: run make report first"; exit 2; }
	$(BIN)/hoopbench findings --results $(RESULTS) $(wildcard $(dir $(RESULTS))finer) \
		$(dir $(RESULTS))stability $(SEARCH_DIRS) --update README.md
	test ! -f $(dir $(RESULTS))hop-top.gif || cp $(dir $(RESULTS))hop-top.gif reports/img/

# The batched engines' cost per world-step goes to $(BENCH_OUT)/batch_cost.csv too, which
# `make report` shows (its section "Cost per world-step by batch size"); until `make bench`
# has run here, the report shows the one measured on the project's 2-core machine
# (reports/bench/measured/: the CPU, no GPU, a loaded machine).
BENCH_OUT := reports/output/bench
BENCH_SHIPPED := reports/bench/measured
# `hoopbench bench` (docs/cli.md): the adapters' overhead, MuJoCo's batches and hop map, and
# the batched engines' costs; BENCH_ARGS narrows it (e.g. BENCH_ARGS="--parts batched").
BENCH_ARGS ?=
bench: $(REPORT_STAMP)
	$(BIN)/hoopbench bench --out $(BENCH_OUT) --force $(BENCH_ARGS)

# docs/report.md's generated blocks (the canonical reading's thresholds and definitions, the
# columns, the verdicts, the tolerances) rewritten from the code's docstrings and tables
# (reports/report/docs.py); tests/test_docs_generated.py fails until this has run.
docs: $(STAMP)
	$(BIN)/python -m hoopbench.reports.report.docs docs/report.md

# mypy checks the package as installed, `hoopbench.*`: from the editable install's tree of
# links (build/__editable__.*/), which the installed package itself points to, so that the
# repository's folders (about/, models/, ...) are never taken for top-level packages.
lint: $(STAMP)
	$(BIN)/ruff check .
	$(BIN)/ruff format --check .
	cd "$$($(BIN)/python -c 'import hoopbench, os; print(os.path.dirname(hoopbench.__path__[0]))')" \
		&& $(CURDIR)/$(BIN)/mypy --config-file $(CURDIR)/pyproject.toml -p hoopbench

format: $(STAMP)
	$(BIN)/ruff format .
	$(BIN)/ruff check --fix .

clean:
	rm -rf $(VENV) build *.egg-info .pytest_cache .ruff_cache
