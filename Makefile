# taskcomplexity — every target installs what it needs first (a bare machine with Python 3.11 is enough).
SHELL := /bin/bash
PYTHON ?= python3.11
VENV := .venv
PY := $(VENV)/bin/python
STAMP := $(VENV)/.installed
ATLAS := $(VENV)/.extra-atlas
METAWORLD := $(VENV)/.extra-atlas,metaworld
DOCS_STAMP := $(VENV)/.extra-dev,docs
TORCH := torch==2.13.0

.DEFAULT_GOAL := help
.PHONY: help install run quick paper paper-jobs beyond classic classic-sweep atlas atlas-cost manipulation manipulation-cost manipulation-cluster test-manipulation atlas-bag atlas-cluster cluster-up cluster-down cluster-cost test test-atlas test-cluster test-avx2 install-avx2 test-all lint docs docs-serve bench fidelity calibrate-contacts clean clean-cache cache-list

# One column of names as wide as the longest, the descriptions wrapped to the terminal under their own column.
help: ## list the targets
	@grep -E '^[a-z0-9-]+:.*## ' $(MAKEFILE_LIST) | awk -F':.*## ' -v cols="$$(tput cols 2>/dev/null || echo 100)" ' \
		{ name[NR] = $$1; text[NR] = $$2; if (length($$1) > width) width = length($$1) } \
		END { indent = width + 9; if (cols < indent + 30) cols = indent + 30; \
		      for (i = 1; i <= NR; i++) { \
		        out = sprintf("  make %-" width "s  ", name[i]); at = indent; n = split(text[i], word, " "); \
		        for (j = 1; j <= n; j++) { \
		          if (at > indent && at + 1 + length(word[j]) > cols) { out = out "\n" sprintf("%" indent "s", ""); at = indent } \
		          else if (at > indent) { out = out " "; at++ } \
		          out = out word[j]; at += length(word[j]) } \
		        print out } }'

$(STAMP): pyproject.toml
	@command -v $(PYTHON) >/dev/null || { echo "error: $(PYTHON) not found (Python 3.11 is required)"; exit 1; }
	@test -x $(PY) || $(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip
	$(PY) -m pip install --quiet $(TORCH)
	$(PY) -m pip install --quiet -e '.[dev]'
	@touch $(STAMP)

# .venv/.extra-<extras>: pip install -e '.[<extras>]', once per change of pyproject.toml (a stamp, as .installed): pip
# reinstalls the package itself on every call, so a command that imports it meanwhile (a study in another shell, a
# test) would fail.
$(VENV)/.extra-%: $(STAMP) pyproject.toml
	$(PY) -m pip install --quiet -e '.[$*]'
	@touch '$@'

# pip compiles the bytecode of what it installs, but not of the package installed in place (-e): compileall does,
# so that a process that may not write bytecode (PYTHONDONTWRITEBYTECODE) does not compile the package at each start.
install: $(STAMP) ## create .venv, install the package with its pinned dependencies and compile its bytecode and numba kernels
	$(PY) -m compileall -q -j 0 src
	$(PY) -m taskcomplexity.commands.compilation

run: $(STAMP) ## the main job: the seven tasks at the published scale (RWG, metrics, diagnostics, verdict, report)
	$(PY) pipelines/study.py experiment=published

quick: $(STAMP) ## a small trial of the whole chain (minutes; not the published scale)
	$(PY) pipelines/study.py experiment=quick

paper: $(STAMP) ## the published protocol with SAC (hours; resumes where it stopped)
	$(PY) pipelines/study.py experiment=published sac.enabled=true

# make paper's SAC runs as a Hydra multirun, one job per study task (its variants and seeds together), e.g. on a
# cluster: make paper-jobs ARGS='hydra/launcher=cluster hydra.launcher.partition=<yours>'; then `make paper`.
STUDY ?= seven_tasks
EXPERIMENT ?= published
paper-jobs: $(STAMP) ## make paper's SAC runs, one job per study task, through a Hydra launcher (ARGS='hydra/launcher=…'); `make paper` then reads them
	$(PY) pipelines/sac.py -m experiment=$(EXPERIMENT) study=$(STUDY) \
		sac.entry=$$($(PY) -m taskcomplexity.commands.study_tasks $(STUDY)) $(ARGS)

beyond: $(STAMP) ## make run + a fifth of the SAC budgets × 2 seeds: the paper's three proposals judged (about an hour)
	$(PY) pipelines/study.py experiment=beyond

classic: $(STAMP) ## the original PIC/POIC protocol on classic control (study=classic_control: N = M = 1000, five tasks)
	$(PY) pipelines/study.py study=classic_control $(ARGS)

atlas: $(ATLAS) ## Furuta et al.'s 13 tasks (classic control, MuJoCo, DM Control) against their Score(A); installs the atlas extra
	$(PY) pipelines/study.py experiment=atlas $(ARGS)

atlas-cost: $(ATLAS) ## what make atlas (with ARGS=… its overrides, e.g. Furuta's N = M = 1000) will cost, from a pilot of each task
	$(PY) pipelines/cost.py experiment=atlas $(ARGS)

# Meta-World's tasks need metaworld 3.1.1, which pins mujoco 3.3.0; installing it with the atlas extra lets pip pick
# the dm-control that runs on that MuJoCo, so make atlas and make manipulation share one consistent virtualenv.
manipulation: $(METAWORLD) ## Meta-World's 50 manipulation tasks against their published difficulty groups (about an hour on 2 cores); installs the metaworld extra
	$(PY) pipelines/study.py experiment=manipulation $(ARGS)

manipulation-cost: $(METAWORLD) ## what make manipulation (with ARGS=… its overrides, e.g. study.policies=100 study.episodes=10) will cost, from a pilot of each task
	$(PY) pipelines/cost.py experiment=manipulation $(ARGS)

# Furuta et al.'s own budget on make atlas's 13 tasks, through a SLURM cluster (the local one of make cluster-up by
# default; PARTITION=<yours> on a real one): priced first (make atlas-cost), then every task's RWG as one job array of
# ATLAS_SHARDS shards per task, then the study (metrics, verdict, report) as one job that reads them from the cache.
PARTITION ?= local
ATLAS_BUDGET ?= study.policies=1000 study.episodes=1000
ATLAS_SHARDS ?= 8
ON_CLUSTER = hydra/launcher=cluster hydra.launcher.partition=$(PARTITION)

atlas-cluster: $(ATLAS) ## Furuta et al.'s budget (13 tasks, N = M = 1000) priced, then sent to SLURM: RWG shards as a job array, the study as a job (PARTITION=<yours>)
	$(PY) pipelines/cost.py experiment=atlas $(ATLAS_BUDGET) rwg.shards=$(ATLAS_SHARDS) $(ON_CLUSTER) $(ARGS)
	$(PY) pipelines/rwg.py -m experiment=atlas $(ATLAS_BUDGET) $(ON_CLUSTER) \
		rwg.entry=$$($(PY) -m taskcomplexity.commands.study_tasks furuta_benchmark) \
		rwg.shards=$(ATLAS_SHARDS) 'rwg.shard=range($(ATLAS_SHARDS))' $(ARGS)
	$(PY) pipelines/study.py -m experiment=atlas $(ATLAS_BUDGET) $(ON_CLUSTER) $(ARGS)

# The 28 cells of Furuta et al.'s sweep: 7 architectures × 4 priors (each cell is one study=classic_control job).
CLASSIC_NETWORKS := pic_linear,pic_h1_4,pic_h1_32,pic_h1_64,pic_h2_4,pic_h2_32,pic_h2_64
CLASSIC_PRIORS := normal,uniform,xavier_normal_tanh,xavier_uniform_tanh

# Furuta et al.'s bag of 56 policy families on make atlas's study: the 28 cells above × with and without a bias.
ATLAS_BAG := network=$(CLASSIC_NETWORKS) prior=$(CLASSIC_PRIORS) network.input_bias=false,true

MANIPULATION_BUDGET ?= study.policies=100 study.episodes=10
MANIPULATION_SHARDS ?= 4

manipulation-cluster: $(METAWORLD) ## Meta-World's 50 tasks at the study's own budget (N = 100, M = 10) priced, then sent to SLURM like atlas-cluster (PARTITION=<yours>)
	$(PY) pipelines/cost.py experiment=manipulation $(MANIPULATION_BUDGET) rwg.shards=$(MANIPULATION_SHARDS) $(ON_CLUSTER) $(ARGS)
	$(PY) pipelines/rwg.py -m experiment=manipulation $(MANIPULATION_BUDGET) $(ON_CLUSTER) \
		rwg.entry=$$($(PY) -m taskcomplexity.commands.study_tasks metaworld) \
		rwg.shards=$(MANIPULATION_SHARDS) 'rwg.shard=range($(MANIPULATION_SHARDS))' $(ARGS)
	$(PY) pipelines/study.py -m experiment=manipulation $(MANIPULATION_BUDGET) $(ON_CLUSTER) $(ARGS)

atlas-bag: $(ATLAS) ## the 56 cells of Furuta et al.'s bag on make atlas's study as a multirun + its sweep report (a cluster job: ARGS='hydra/launcher=cluster …')
	$(PY) pipelines/study.py -m experiment=atlas $(ATLAS_BAG) $(ARGS)

classic-sweep: $(STAMP) ## the 28 network × prior cells of study=classic_control as a multirun + its sweep report (ARGS=… adds overrides, e.g. a launcher)
	$(PY) pipelines/study.py -m study=classic_control network=$(CLASSIC_NETWORKS) prior=$(CLASSIC_PRIORS) $(ARGS)

# pytest-xdist: one worker per core, each test file on one worker (its module fixtures are computed once), the
# files in the order tests/conftest.py collects them (the longest first).
XDIST := -n auto --dist loadfile --no-loadscope-reorder

test: $(STAMP) ## run the test suite (CI runs it beside make test-cluster, then make test-atlas, and make test-avx2 where the CPU has AVX-512)
	$(PY) -m pytest -q -m "not slow and not cluster" $(XDIST)

# The tests that pin numbers (golden runs, the kernels against their references, the backends against PyBullet).
PINNED_TESTS := tests/golden tests/metrics/test_log_mean_exp.py tests/tasks/test_batched.py \
	tests/tasks/test_rollout_kernel.py tests/tasks/test_step_kernel.py tests/tasks/test_contact.py \
	tests/tasks/test_noisy_cartpole.py tests/policies/test_tanh.py

# The tests that run only with the atlas extra (MuJoCo, DM Control, EnvPool); make test skips them without it.
ATLAS_TESTS := tests/rwg/test_envpool_backend.py tests/tasks/test_gym_task.py tests/policies/test_policies.py

test-atlas: $(ATLAS) ## installs the atlas extra and runs the tests that need it: EnvPool against gymnasium per task (minutes)
	$(PY) -m pytest -q $(XDIST) $(ATLAS_TESTS)

# A single-node SLURM cluster on this machine (Debian's slurm-wlm, munge and MariaDB; root), partition `local`: the
# scheduler the cluster path is tested on. Its state and logs live in outputs/cluster.
CLUSTER := cluster/local_slurm.sh

cluster-up: ## start a single-node SLURM cluster on this machine, partition `local` (installs it first; needs root)
	bash $(CLUSTER) up

cluster-down: ## stop the local SLURM cluster: its jobs cancelled, its daemons stopped (logs stay in outputs/cluster/log)
	bash $(CLUSTER) down

cluster-cost: $(ATLAS) cluster-up ## make atlas-cost's prediction beside the CPU the local cluster's jobs used (sacct), per task (ARGS=<overrides>)
	$(PY) bench/cluster_cost.py $(ARGS)

test-manipulation: $(METAWORLD) ## installs the metaworld extra and runs the tests that need it: every Meta-World task seeded per episode (a minute)
	$(PY) -m pytest -q tests/tasks/test_manipulation.py

# The cluster tests to run (a pytest -m expression): CI runs those that wait on SLURM beside make test, and the ones
# that install an extra into .venv (marker `installs`) after it, alone (.ci/run). CLUSTER_PATHS: the files or folders
# pytest collects them from (empty: the whole suite; collecting it imports every test module, ~12 CPU-s).
CLUSTER_TESTS ?= cluster
CLUSTER_PATHS ?=

test-cluster: $(STAMP) cluster-up ## the tests that send jobs to SLURM, on the local cluster (starts it; make cluster-down stops it)
	$(PY) -m pytest -q -m "$(CLUSTER_TESTS)" $(CLUSTER_PATHS)

# numba's cache of the AVX2 path's kernels (kept beside .venv's packages: a second run loads them).
AVX2_NUMBA_CACHE := $(VENV)/numba-avx2

test-avx2: $(STAMP) ## the tests that pin numbers, on the AVX2 path of numba, NumPy, torch and the BLAS (CI's second pass, on a CPU with a path wider than AVX2)
	$(PY) tests/cpu_paths.py --numba-cache $(AVX2_NUMBA_CACHE) -- $(PY) -m pytest -q -m "not slow" $(XDIST) $(PINNED_TESTS)

install-avx2: $(STAMP) ## compile the AVX2 path's kernels ahead, as make install does the native ones (into .venv/numba-avx2, what make test-avx2 loads)
	$(PY) tests/cpu_paths.py --numba-cache $(AVX2_NUMBA_CACHE) -- $(PY) -m taskcomplexity.commands.compilation

test-all: $(STAMP) cluster-up ## every test, including the slow learning checks and the cluster's
	$(PY) -m pytest -q

lint: $(STAMP) ## ruff
	$(VENV)/bin/ruff check src tests pipelines bench

docs: $(DOCS_STAMP) ## build the documentation site into site/ with --strict
	NO_MKDOCS_2_WARNING=1 DISABLE_MKDOCS_2_WARNING=true $(VENV)/bin/mkdocs build --strict --site-dir site

docs-serve: $(DOCS_STAMP) ## serve the documentation at http://127.0.0.1:8000 while you edit it
	NO_MKDOCS_2_WARNING=1 DISABLE_MKDOCS_2_WARNING=true $(VENV)/bin/mkdocs serve --dev-addr 127.0.0.1:8000

bench: $(METAWORLD) ## benchmarks: figures and ratios measured side by side (installs the atlas and metaworld extras for bench_mujoco and bench_metaworld)
	$(PY) bench/run.py $(ARGS)

fidelity: $(STAMP) ## Table 1 at the published scale beside the published cells, with the probes of docs/explanation/fidelity.md (ARGS=--scan: + the torque scan)
	$(PY) bench/fidelity.py $(ARGS)

calibrate-contacts: $(STAMP) ## measure the obstacle contact model's one-sweep rates on PyBullet, beside the constants (minutes)
	$(PY) bench/calibrate_contacts.py

cache-list: $(STAMP) ## list cached artefacts with their sizes
	$(PY) -m taskcomplexity.stages.cache list

clean-cache: ## delete outputs/cache
	rm -rf outputs/cache

clean: ## delete the virtualenv, all outputs and the built documentation
	rm -rf $(VENV) outputs/cache outputs/runs outputs/reports outputs/tables site
