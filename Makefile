# stlplan developer targets. `make help` lists them.
PYTHON ?= python3
VENV   ?= .venv
BIN    := $(VENV)/bin
STAMP  := $(VENV)/.installed
OUT    ?= out/farm

.DEFAULT_GOAL := help
.PHONY: help install farm test test-heavy test-slow fuzz smoke bench bench-quick bench-replan bench-simulate bench-profile bench-scale bench-tasks lint format schema crowd clean

help:  ## List the targets
	@grep -E '^[a-zA-Z_-]+:.*?## ' $(MAKEFILE_LIST) | awk 'BEGIN {FS = ":.*?## "}; {printf "  %-15s %s\n", $$1, $$2}'

$(STAMP): pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(BIN)/pip install --quiet --upgrade pip
	$(BIN)/pip install --quiet -e '.[dev,dask]'
	touch $(STAMP)

install: $(STAMP)  ## Create .venv and install stlplan with its development tools

farm: $(STAMP)  ## Solve the shipped farm mission (Case I) into out/farm
	$(BIN)/stlplan solve missions/farm.yaml --out $(OUT)

TEST_WORKERS ?= 2
# loadfile: a test module runs on one worker, which builds its module fixtures (a solved mission,
# the browser) once; with tests of a module on both workers, both built them.
# PYTHONDONTWRITEBYTECODE emptied: the workers and the stlplan processes the tests start keep the
# compiled modules and pytest's rewritten test modules instead of compiling them again each time.
PYTEST_PARALLEL = PYTHONDONTWRITEBYTECODE= $(BIN)/pytest -q -n $(TEST_WORKERS) --dist loadfile --durations=15
test: $(STAMP)  ## Run the test suite (without the heavy tests and the slow solves) on TEST_WORKERS processes (2), listing the 15 slowest tests
	$(PYTEST_PARALLEL) -m "not slow and not heavy"

test-heavy: $(STAMP)  ## Run only the heavy tests (several seconds each: benches, sweeps, closed loops, crowds), as CI does after make test
	$(PYTEST_PARALLEL) -m heavy

test-slow: $(STAMP)  ## Run only the slow tests (full farm solves, the STL suite against its reference)
	$(BIN)/pytest -q -m slow

fuzz: $(STAMP)  ## Fuzz formulas and mission files with 5000 fresh random Hypothesis examples per test
	STLPLAN_HYPOTHESIS=explore STLPLAN_FUZZ_EXAMPLES=5000 $(BIN)/pytest -q tests/test_fuzz.py

SMOKE_LIMIT ?= 180
smoke: $(STAMP)  ## Solve Cases I-III once each under a time limit; fail unless every plan is accepted
	@for m in farm farm-case2 farm-case3; do \
	  $(BIN)/stlplan solve missions/$$m.yaml --out out/smoke/$$m --time-limit $(SMOKE_LIMIT) --quiet || exit 1; \
	done

bench: $(STAMP)  ## Benchmark Cases I-III (30 states, straightforward on 2), then the STL suite and Cases I-III with both encodings, replanning and simulation (~3.5 h)
	$(BIN)/python -m stlplan.bench --runs 30 --formulations default sampled --compare-runs 2 --compare-time-limit 600
	$(BIN)/python -m stlplan.bench --cases suite farm farm-case2 farm-case3 --runs 3 --formulations log standard --base log --compare-runs 0 --time-limit 300 --threads 1 --name bench-encodings
	$(BIN)/python -m stlplan.replan_bench --out bench-results/replan
	$(BIN)/python -m stlplan.sim_bench --out bench-results/simulation --curves

bench-replan: $(STAMP)  ## Replanning Case I after drift (K = 2..7, W = 0.05), after losing vis1 at 4 or uv1 at 2, after closing A2 at 3 (~6 min)
	$(BIN)/python -m stlplan.replan_bench --out bench-results/replan

bench-simulate: $(STAMP)  ## Case I executed 20 times under W = 0.02: robust vs nominal, replanning vs open loop, vis1 lost; fraction satisfied against W (~1 h)
	$(BIN)/python -m stlplan.sim_bench --out bench-results/simulation --curves

bench-profile: $(STAMP)  ## Where the time of Cases I-III goes: rounds, requirements added and binding by kind, nodes, first plan (3 states each, both semantics, ~15 min)
	$(BIN)/python -m stlplan.profile_bench --out bench-results/profile

bench-scale: $(STAMP)  ## The scaled farms (16, 24, 32 agents), 5 states each, 2 threads: plans found, first plan, gap at 600 s (~2.5 h)
	$(BIN)/python -m stlplan.bench --cases scale/farm-x2 scale/farm-x3 scale/farm-x4 --runs 5 --formulations default --compare-runs 0 --time-limit 600 --threads 2 --name bench-scale

bench-tasks: $(STAMP)  ## Case I and the scaled farms, 3 states each: tasks by selection against groups (~2.5 h)
	$(BIN)/python -m stlplan.bench --cases farm scale/farm-x2-same scale/farm-x2 scale/farm-x3 scale/farm-x4 --runs 3 --formulations default groups --compare-runs 0 --time-limit 600 --name bench-tasks

bench-quick: $(STAMP)  ## Benchmark Cases I-III on 2 states each, straightforward on 1 of Case I, the STL suite with both encodings (~20 min)
	$(BIN)/python -m stlplan.bench --runs 2 --formulations default sampled --compare-runs 1 --compare-cases farm --compare-time-limit 300 --name bench-quick
	$(BIN)/python -m stlplan.bench --cases suite --formulations log standard --base log --compare-runs 0 --time-limit 60 --threads 1 --name bench-quick-encodings

lint: $(STAMP)  ## ruff check, ruff format --check, mypy
	$(BIN)/ruff check stlplan tests
	$(BIN)/ruff format --check stlplan tests
	$(BIN)/mypy stlplan

format: $(STAMP)  ## Apply ruff's formatting and safe fixes
	$(BIN)/ruff check --fix stlplan tests
	$(BIN)/ruff format stlplan tests

schema: $(STAMP)  ## Regenerate schemas/mission.schema.json
	$(BIN)/stlplan schema

crowd: $(STAMP)  ## Regenerate missions/crowd/*.yaml (antipodal swaps of 16, 32 and 64 agents)
	$(BIN)/python -m stlplan.crowd --out missions/crowd

clean:  ## Remove the virtual environment, caches and outputs
	rm -rf $(VENV) out .pytest_cache .mypy_cache .ruff_cache .hypothesis
