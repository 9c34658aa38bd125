# shapegrowth: `make run` (the default scene end to end) and `make test`.
# Both install what they need (Debian packages, .venv) when it is missing.
SHELL := /bin/bash
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.setup-done
NP ?= 2

# The JIT cache of compiled forms stays inside the checkout.
export XDG_CACHE_HOME ?= $(CURDIR)/.cache
# OpenMPI refuses root without these; CI runs as root on 2 cores.
export OMPI_ALLOW_RUN_AS_ROOT := 1
export OMPI_ALLOW_RUN_AS_ROOT_CONFIRM := 1
export OMPI_MCA_rmaps_base_oversubscribe := 1
MPIRUN := mpirun -n $(NP)
# OpenBLAS's kernels named for this CPU's vector units, where the user has not named them: a
# CPU newer than Debian's OpenBLAS runs its SSE3 kernels, several times slower
# (shapegrowth/blas.py). The command line sets it itself; the tests and notebooks load numpy
# before it could, so it is set here for every recipe.
ifeq ($(origin OPENBLAS_CORETYPE),undefined)
OPENBLAS_CORETYPE := $(shell /usr/bin/python3 -c 'from shapegrowth.blas import openblas_coretype; print(openblas_coretype() or "")' 2>/dev/null)
endif
ifneq ($(OPENBLAS_CORETYPE),)
export OPENBLAS_CORETYPE
endif

.PHONY: reachable setup run bend test test-all test-hex notebooks-mpi test-debian13 test-dolfinx011 lint test-serial test-mpi test-serial-slow test-mpi-slow notebooks bench reproduce reproduce-twice reproduce-models reproduce-cube reproduce-compare reference-docs clean help

help:
	@echo "make run    - scene 1 end to end on $(NP) ranks, verified on the 3D beam (installs what is missing)"
	@echo "make bend   - the forward model alone: a beam bent into a half circle"
	@echo "make test   - the fast tier: lint, types, tests serial and under mpirun -n $(NP) (minutes)"
	@echo "make test-all - the rest: each slow test once (serially, or under mpirun where marked mpi), the fast tier on hexahedra (test-hex), the notebooks"
	@echo "make test-debian13 - the fast tier in a Debian 13 root (dolfinx 0.9; root, debootstrap)"
	@echo "make test-dolfinx011 - the fast tier on dolfinx 0.11's pip wheels in that root (root)"
	@echo "make notebooks - execute the notebooks (writes the .ipynb), then each under mpirun"
	@echo "make notebooks-mpi - each notebook as a script under mpirun -n $(NP) only (what CI runs)"
	@echo "make bench  - the performance benchmark (results/bench/bench.json, minutes)"
	@echo "make reproduce - every paper scene under mpirun on its winning model, then docs/RESULTS.md (33-67 min on 2 cores)"
	@echo "make reproduce-models - each scene's other model beside it (23 min)"
	@echo "make reproduce-twice - the reproduction's runs verified on their meshes refined once more"
	@echo "make reproduce-cube - scene 6 as the paper ran it: the 3D cube, fixed against free frame (23 min)"
	@echo "make reproduce-compare OTHER=DIR - results/reproduce against a second reproduction's run folders"
	@echo "make reachable - targets a known growth produces, found again (docs/REACHABLE.md)"
	@echo "make setup  - Debian packages and .venv only"

setup: $(STAMP)

$(STAMP): pyproject.toml scripts/setup.sh
	@scripts/setup.sh
	@touch $@

# The default scene by the project's best route for it: scene 1's X1-X3 section (plane
# stress), coarse to fine, its growth lifted onto the 3D beam and grown from rest there
# (measured on 2 cores: 3 min 49 s, lifted 0.89 % verified).
run: setup
	$(MPIRUN) $(BIN)/shapegrowth run configs/beam_wave_2d.yaml --out results/beam_wave_2d

# The forward model alone: the beam bent into a half circle by a compatible growth.
bend: setup
	$(BIN)/shapegrowth solve configs/beam_bend.yaml --probe 1,0,0

# The fast tier (tests not marked `slow`; tests/conftest.py fails an unmarked test that takes
# more than SHAPEGROWTH_FAST_LIMIT_S seconds) and the rest; CI runs both, then Debian 13's
test: setup
	@$(MAKE) --no-print-directory lint test-serial test-mpi

test-all: setup
	@$(MAKE) --no-print-directory test-serial-slow test-mpi-slow test-hex notebooks

# The fast tier again with every config on quadrilaterals and hexahedra (mesh.cells: hex
# where a test does not name its cells; tests/conftest.py), serially and on $(NP) ranks; the
# tests marked `simplex` assert something of simplices and are left out
test-hex: setup
	SHAPEGROWTH_TEST_CELLS=hex SHAPEGROWTH_FAST_LIMIT_S=0 $(SERIAL) -m "not slow and not simplex" tests
	@SHAPEGROWTH_TEST_CELLS=hex SHAPEGROWTH_FAST_LIMIT_S=0 OPENBLAS_NUM_THREADS=1 timeout 1200 $(MPIRUN) scripts/rank0-output.sh $(PYTEST) --color=no -m "mpi and not slow and not simplex" tests \
	  || { tail -n 40 .cache/rank-*.log; exit 1; }

# The whole suite again inside a Debian 13 root (dolfinx 0.9.0, PETSc 3.22), built once and
# cached in ~/.cache/shapegrowth/debian13; skipped with one line where it cannot run
test-debian13:
	@scripts/debian13.sh

# The fast tier on dolfinx 0.11 (the pip wheel dolfinx-solver-real, the extra `wheels`) in a
# venv inside that root, serially and on two ranks; skipped with one line where it cannot run
test-dolfinx011:
	@scripts/dolfinx011.sh

# ruff on the package, its tests, scripts, benchmarks and notebook sources, and mypy on the
# package, its scripts and benchmarks (configured in pyproject.toml; the dolfinx 0.11 leg
# checks the package alone: the scripts call petsc4py, whose stubs there differ from Debian's)
lint:
	$(BIN)/ruff check shapegrowth tests scripts benchmarks notebooks
	$(BIN)/mypy
	$(BIN)/mypy scripts benchmarks

PYTEST := $(BIN)/python -m pytest -q --durations=15
# The serial tiers on $(NP) pytest-xdist workers, one BLAS thread each, a test file's tests on
# one worker in the file's order (their module fixtures built once, their random draws the
# serial run's). Measured on this machine (2 cores), a fresh clone of 47dba76: the fast
# serial tier 4:43 on two workers; before the tier was trimmed to 567 tests, its 600 took
# 5:17 on an empty form cache and 2:55 on a full one.
SERIAL := OPENBLAS_NUM_THREADS=1 $(PYTEST) -n $(NP) --dist loadfile

test-serial:
	$(SERIAL) -m "not slow" tests

# Each slow test runs once: serially, or where it is marked `mpi`, under mpirun in
# test-mpi-slow (the fast tier runs its `mpi` tests both ways). Measured on a fresh clone of
# ac9a6b1 beside other work: the slow tier serially, mpi ones included, 27 min, of which
# those ran again on two ranks in 9.
test-serial-slow:
	$(SERIAL) -m "slow and not mpi" tests

# Tests marked `mpi` run again on $(NP) ranks; the other ranks' reports go to
# .cache/rank-N.log and are shown only if the run fails.
# A failure on one rank only can leave the others waiting in a collective: the
# timeout turns such a hang into a failure, and a test still running after 300 s (the
# slowest takes 72) writes every rank's stack, which names the collective each waits in.
MPI_PYTEST := $(PYTEST) --color=no -o faulthandler_timeout=300

test-mpi:
	@OPENBLAS_NUM_THREADS=1 timeout 1200 $(MPIRUN) scripts/rank0-output.sh $(MPI_PYTEST) -m "mpi and not slow and not mpi_slow" tests \
	  || { tail -n 60 .cache/rank-*.log; exit 1; }

test-mpi-slow:
	@OPENBLAS_NUM_THREADS=1 timeout 1800 $(MPIRUN) scripts/rank0-output.sh $(MPI_PYTEST) -m "mpi and (slow or mpi_slow)" tests \
	  || { tail -n 60 .cache/rank-*.log; exit 1; }

# The notebooks: executed from their jupytext sources (the .ipynb are rewritten with
# their outputs), then each source run as a script under mpirun (notebooks-mpi, the pass CI
# runs: the same cells, on two ranks).
notebooks: setup
	$(BIN)/python scripts/run_notebooks.py
	@$(MAKE) --no-print-directory notebooks-mpi

notebooks-mpi: setup
	@mkdir -p .cache
	@for nb in notebooks/[0-9]*.py; do \
	  echo "$$nb under mpirun -n $(NP)"; \
	  MPLBACKEND=Agg OPENBLAS_NUM_THREADS=1 timeout 900 $(MPIRUN) $(BIN)/python $$nb > .cache/notebook-mpi.log 2>&1 \
	    || { tail -n 40 .cache/notebook-mpi.log; exit 1; }; \
	done

bench: setup
	$(BIN)/shapegrowth bench

# The paper's scenes under mpirun -n $(NP), each on the model that wins, resumable, then
# docs/RESULTS.md from the runs (33 min on the last machine's 2 cores, 67 on one 2x slower;
# an interrupted reproduction continues where it stopped).
reproduce: setup
	$(BIN)/python scripts/reproduce.py --ranks $(NP)

# The verification verified: each finished run of the reproduction on its mesh refined once
# more (verify-rN/verify.json beside each run, tabled in docs/RESULTS.md; resumable)
reproduce-twice: setup
	$(BIN)/python scripts/reproduce.py --ranks $(NP) --twice

# Each scene's other model beside the reproduction (the 3D beams and shell, the disk's
# section: the measurements of which model wins; 23 min; RESULTS.md gains their rows)
reproduce-models: setup
	$(BIN)/python scripts/reproduce.py --ranks $(NP) --models

# Scene 6's 3D cube beside the reproduction (four runs; RESULTS.md gains their rows)
reproduce-cube: setup
	$(BIN)/python scripts/reproduce.py --ranks $(NP) --cube

# Targets a known growth produces, found again from no growth with the defaults, every
# algorithm beside (docs/REACHABLE.md; about 15 min)
reachable: setup
	$(BIN)/python scripts/reachable.py --algorithms mma,slsqp

# docs/REPRODUCIBILITY.md: this clone's reproduction against another's (exit 1 beyond 5 %); the sections
# measured by hand below its KEPT line are kept
reproduce-compare: setup
	@test -n "$(OTHER)" || { echo "reproduce-compare: set OTHER=<another clone>/results/reproduce"; exit 2; }
	$(BIN)/python scripts/reproduce.py --compare $(OTHER)

# docs/CONFIG.md from the schema (a test checks that it is current)
reference-docs: setup
	$(BIN)/python scripts/config_reference.py

clean:
	rm -rf results .cache meshes/*.msh meshes/*.json
