# The front door. `make figures` reproduces every figure of the paper; `make test` runs the tests.
# Both install missing Debian packages first (as root; otherwise they print the command).
PYTHON  := /usr/bin/python3
BUILD   := build
RESULTS := results
JOBS    ?= 2
RUN     := $(BUILD)/experiments

.PHONY: all figures test test-petsc petsc-build test-mpi mpi-build bench-mpi sanitize bench bench-amg deps build fig3 fig4 fig5 fig6 \
        compare hertz readings reference keys format clean verify verify-fig6 peer-deps \
        peer-reference bench-peer install paper-vs-package peel oring vgroove

all: figures

deps:
	@bash .ci/deps.sh

build: deps
	@cmake -S . -B $(BUILD) -DCMAKE_BUILD_TYPE=Release > /dev/null
	@cmake --build $(BUILD) -j $(JOBS)

# Installs ltl_run, the Python reader ltl_results.py and its ltl-results command under PREFIX.
PREFIX ?= /usr/local
install: build
	cmake --install $(BUILD) --prefix $(PREFIX)

test: build
	cd $(BUILD) && OMP_NUM_THREADS=2 ctest --output-on-failure -j $(JOBS)

# The CG + AMG global step's tests (tests/test_cg_amg.cpp) and those of Newton's Krylov solves
# (tests/test_newton_krylov.cpp) with PETSc: installs Debian's
# petsc-dev (as root; otherwise prints the command), builds with it and runs them; a PETSc that
# is still missing fails them (LTL_REQUIRE_PETSC). `make test` never needs PETSc: there these
# tests report themselves skipped. .ci/deps.sh does not install it.
# The CG + AMG global step (PETSc, optional): its own build in build-petsc/ (installs petsc-dev
# as root, else prints the command), then its tests.
PETSC_BUILD := build-petsc
petsc-build:
	@pkg-config --exists PETSc || { if [ "$$(id -u)" = 0 ]; then apt-get update && \
	  DEBIAN_FRONTEND=noninteractive apt-get install -y petsc-dev; else \
	  echo "run as root: apt-get install -y petsc-dev"; exit 1; fi; }
	@cmake -S . -B $(PETSC_BUILD) -DCMAKE_BUILD_TYPE=Release -DLTL_WITH_PETSC=ON > /dev/null
	@cmake --build $(PETSC_BUILD) -j $(JOBS) --target test_cg_amg test_newton_krylov bench_amg

test-petsc: petsc-build
	cd $(PETSC_BUILD) && LTL_REQUIRE_PETSC=1 OMP_NUM_THREADS=2 ctest --output-on-failure -j $(JOBS) -R 'CgAmg|NewtonKrylov'

# ALG2 over MPI ranks (optional; lib/alg2_mpi.cpp, paper_notes/mpi.md): its own build in
# build-mpi/ with -DLTL_WITH_MPI=ON (PETSc with its MPI: installs petsc-dev as root, else prints
# the command), then its tests under mpirun with 1, 2 and 3 ranks (3 oversubscribed) and ltl_run
# under mpirun -n 2 (ctest label "mpi"; about 2 min on the 2-core machine). `make test` never
# needs MPI. Run as root, mpirun needs OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
# (set by the tests and the benchmark).
MPI_BUILD := build-mpi
mpi-build:
	@pkg-config --exists PETSc || { if [ "$$(id -u)" = 0 ]; then apt-get update && \
	  DEBIAN_FRONTEND=noninteractive apt-get install -y petsc-dev; else \
	  echo "run as root: apt-get install -y petsc-dev"; exit 1; fi; }
	@cmake -S . -B $(MPI_BUILD) -DCMAKE_BUILD_TYPE=Release -DLTL_WITH_MPI=ON > /dev/null
	@cmake --build $(MPI_BUILD) -j $(JOBS) --target ltl_run mpi_ranks bench_mpi bench_mpi_newton \
	  test_cg_amg test_newton_krylov

# The MPI build has PETSc: its tests also run the PETSc ones (CG + AMG, Newton's Krylov solves),
# which `make test` reports skipped.
test-mpi: mpi-build
	cd $(MPI_BUILD) && ctest --output-on-failure -L mpi && \
	  LTL_REQUIRE_PETSC=1 ctest --output-on-failure -j $(JOBS) -R 'CgAmg|NewtonKrylov'

# The cost of a distributed ALG2 iteration on refined gutters, 1, 2 and 4 (oversubscribed)
# ranks, strong and weak scaling: the phases, the bytes each rank receives per iteration, the
# peak memory per rank (experiments/bench/bench_mpi.sh; the table of paper_notes/mpi.md).
# BENCH_MPI_ARGS=--quick: the two smaller gutters only.
BENCH_MPI_ARGS ?=
bench-mpi: mpi-build
	sh experiments/bench/bench_mpi.sh $(MPI_BUILD) $(BENCH_MPI_ARGS)

# The whole test suite under AddressSanitizer + UndefinedBehaviorSanitizer, in build-sanitize.
# EIGEN_MALLOC_ALREADY_ALIGNED=1: Eigen then allocates with plain malloc/free, as libgmsh's own
# Eigen does; otherwise ASan reports a bad-free when a gmsh-allocated Eigen array is freed here.
# Leak checking is off (libgmsh and OpenMP keep allocations until exit). The Fig 3 exact-kernel
# regression takes ~6 min under ASan; skip it with SANITIZE_CTEST="-E exact_kernel".
# -O1 -g (ASan's recommended level): at -O2 the build did not fit a loaded machine.
# test_memory (its own malloc) is not built here (tests/CMakeLists.txt).
# Last full run (hostile inputs, round two; GCC 12, JOBS=2 on 2 cores shared with two other
# builds and test suites, load average 6-9): build from scratch 41 min, then stopped by
# test_memory crashing at test discovery (fixed: not built under ASan); the build resumed
# (incremental, 23 min); ctest 364 tests in 25 min (1489 s): 357 passed, 7 skipped by design (4 CG + AMG
# without PETSc, the 2 address-space-limit cases, the disk-full tmpfs that could not be mounted),
# none failed, no ASan or UBSan report. Second invocation wall time 48 min (build + ctest).
SANITIZE_FLAGS := -fsanitize=address,undefined -fno-omit-frame-pointer -fno-sanitize-recover=undefined \
                  -DEIGEN_MALLOC_ALREADY_ALIGNED=1
SANITIZE_CTEST ?=
sanitize: deps
	@cmake -S . -B build-sanitize -DCMAKE_BUILD_TYPE=RelWithDebInfo \
	  -DCMAKE_C_FLAGS_RELWITHDEBINFO="-O1 -g -DNDEBUG" -DCMAKE_CXX_FLAGS_RELWITHDEBINFO="-O1 -g -DNDEBUG" \
	  -DCMAKE_C_FLAGS="$(SANITIZE_FLAGS)" -DCMAKE_CXX_FLAGS="$(SANITIZE_FLAGS)" \
	  -DCMAKE_EXE_LINKER_FLAGS="-fsanitize=address,undefined" > /dev/null
	@cmake --build build-sanitize -j $(JOBS)
	cd build-sanitize && ASAN_OPTIONS=detect_leaks=0:abort_on_error=0 \
	  UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1 OMP_NUM_THREADS=2 \
	  ctest --output-on-failure -j $(JOBS) $(SANITIZE_CTEST)

figures: fig3 fig4 fig5 fig6 paper-vs-package

# The paper's stated iterations and CPU beside ours (results/paper_vs_package.png): plain ALG2
# from the figure runs above (results/figN.h5), and the same configurations with Anderson
# acceleration and with the Newton phase, in results/paper_vs_package/.
# Needs results/figN.h5 (`make figures` makes them first); about a minute on 2 shared cores.
PVP := $(RESULTS)/paper_vs_package
paper-vs-package: build
	@mkdir -p $(PVP)
	for f in fig3 fig4 fig5 fig6; do $(RUN)/ltl_run experiments/$$f/$$f.toml -q \
	  -o $(PVP)/$$f-anderson.h5 --set algorithm.acceleration=anderson || exit 1; done
	for f in fig3 fig4 fig5 fig6; do $(RUN)/ltl_run experiments/$$f/$$f.toml -q \
	  -o $(PVP)/$$f-newton.h5 --set algorithm.solver=newton || exit 1; done
	$(PYTHON) figures/paper_vs_package.py $(RESULTS) $(RESULTS)/paper_vs_package.png

# A displacement-controlled peel (experiments/peel/): the free end of a glued strip lifted by a
# ramped prescribed displacement, then `ltl-results plot` of the run (results/peel.png: the
# reaction against the lift, the convergence, beta over time).
peel: build
	@mkdir -p $(RESULTS)
	$(RUN)/ltl_run experiments/peel/peel.toml -o $(RESULTS)/peel.h5
	$(PYTHON) figures/ltl_results.py plot $(RESULTS)/peel.h5 -o $(RESULTS)/peel.png

# Several rigid obstacles ([[contact]], paper_notes/obstacles.md): a pressurized ring between two
# plates (experiments/oring/) and a block pressed into a V-groove (experiments/vgroove/), each
# run, then drawn (deformed mesh, contact pressure per obstacle) from its HDF5 file.
oring vgroove: build
	@mkdir -p $(RESULTS)
	$(RUN)/ltl_run experiments/$@/$@.toml -o $(RESULTS)/$@.h5
	$(PYTHON) experiments/$@/plot_$@.py $(RESULTS)/$@.h5 $(RESULTS)/$@.png

# One target per paper figure: run the driver (HDF5 in results/), then plot from the HDF5 only.
# Figs 3 and 4 draw two readings of the paper's data: figN.png the one the readings study finds
# closest to the caption (R3, pressed down), figN_literal.png the literal one (R1, pulled up).
fig5 fig6: build
	@mkdir -p $(RESULTS)
	$(RUN)/$@ experiments/$@/$@.toml -o $(RESULTS)/$@.h5
	$(PYTHON) figures/$@.py $(RESULTS)/$@.h5 $(RESULTS)/$@.png

fig3 fig4: build
	@mkdir -p $(RESULTS)
	$(RUN)/$@ experiments/$@/$@.toml -o $(RESULTS)/$@.h5
	$(PYTHON) figures/$@.py $(RESULTS)/$@.h5 $(RESULTS)/$@.png
	@# The literal reading may be refused at a step (Fig 4: a cell folds at the clamp once the glue
	@# lets go, paper_notes/admissibility.md); its figure draws the steps it kept.
	$(RUN)/$@ experiments/$@/$@_literal.toml -o $(RESULTS)/$@_literal.h5 || \
	  echo "$@_literal: the run was refused at a step (above); drawing the steps it kept"
	$(PYTHON) figures/$@.py $(RESULTS)/$@_literal.h5 $(RESULTS)/$@_literal.png

# Which reading of the paper's data gives the captions of Figs 3 and 4 (paper_notes/readings.md):
# every reading x kernel rule x q_c, one HDF5 per run in results/readings/, then one page
# (table + plots) from those files only, and the hand estimates checked against the runs.
readings: build
	@mkdir -p $(RESULTS)/readings
	$(PYTHON) experiments/readings/run_readings.py --bin $(RUN)/ltl_run --out $(RESULTS)/readings \
		--mesh --jobs $(JOBS)
	$(PYTHON) figures/readings.py $(RESULTS)/readings $(RESULTS)/readings.pdf
	$(PYTHON) experiments/readings/hand_estimates.py $(RESULTS)/readings

# Uzawa vs Bermudez-Moreno on every figure's problem, with sweeps of R and rho.
compare: build
	@mkdir -p $(RESULTS)/compare
	$(RUN)/compare $(RESULTS)/compare
	$(RUN)/hertz 2 0.1 0.75 $(RESULTS)/compare
	$(PYTHON) figures/compare.py $(RESULTS)/compare $(RESULTS)/compare.pdf

# Section 7: the Signorini solver against Hertz under mesh refinement, both updates.
hertz: build
	$(RUN)/hertz

# The package against the independent dolfinx Newton solver under refinement (Figs 5 and 6):
# both codes on the same gmsh meshes, then figures/verify.py draws values and errors against h
# with the fitted orders. Installs python3-dolfinx python3-gmsh (never needed by `make test`).
VERIFY := $(RESULTS)/verify
FIG5_LEVELS ?= 7 14 28 56
FIG6_LEVELS ?= 1 2
peer-deps:
	@bash .ci/deps.sh peer

verify: build peer-deps
	@mkdir -p $(VERIFY)
	$(RUN)/refinement fig5 levels=$(shell echo $(FIG5_LEVELS) | tr ' ' ',') json=$(VERIFY)/fig5_ltl.json
	OMP_NUM_THREADS=1 $(PYTHON) experiments/peer/peer.py fig5 --levels $(FIG5_LEVELS) --out $(VERIFY)/fig5_peer.json
	$(PYTHON) figures/verify.py $(VERIFY) $(RESULTS)/verify.png

# Fig 6 likewise. The peer as Q1/P0 mean dilatation on the package's H8 geometry (the package's
# own discrete problem): arc-length continuation onto the plane on levels 1 and 2, then Newton on
# each finer level from the previous level's state interpolated (paper_notes/discretization.md,
# "Fig 6 peer"; its Q2/Q1 run does not yet pass a critical point of the path at 5 % of the load).
FIG6_PEER_NESTED ?= 3 4
verify-fig6: build peer-deps
	@mkdir -p $(VERIFY)/state
	$(RUN)/refinement fig6 levels=$(shell echo $(FIG6_LEVELS) | tr ' ' ',') json=$(VERIFY)/fig6_ltl.json
	OMP_NUM_THREADS=1 $(PYTHON) experiments/peer/peer.py fig6 --element q1p0 --levels 1 2 --save $(VERIFY)/state/q1 --out $(VERIFY)/fig6_peer_q1p0.json
	for L in $(FIG6_PEER_NESTED); do OMP_NUM_THREADS=1 $(PYTHON) experiments/peer/peer.py fig6 --element q1p0 \
	  --levels $$L --strategy nested --init $(VERIFY)/state/q1_L$$((L - 1)).npz --save $(VERIFY)/state/q1 \
	  --out $(VERIFY)/fig6_peer_q1p0.json || exit 1; done
	$(PYTHON) figures/verify.py $(VERIFY) $(RESULTS)/verify.png

# Freeze the peer's converged values (after `make verify`) as tests/reference/peer.toml;
# PEER_FIGS=fig6 rewrites only that figure's sections.
peer-reference:
	$(PYTHON) experiments/peer/make_reference.py $(VERIFY) tests/reference/peer.toml $(PEER_FIGS)

# Time to the same accuracy against the dolfinx Newton peer: Fig 5 K = 7, 28
# and Fig 6 L = 1 with the package plain and Anderson on 1 and 2 threads, Fig 5 K = 56 and Fig 6
# L = 2 with Anderson on 1 thread (BENCH_PEER_ARGS=--full: everything everywhere, ~45 min;
# --quick: the small cases only); the package at tol = 1e-3, 1e-4, ... against one Newton run;
# whole-process CPU and wall to 1e-3 and 1e-6 in the observable and the equilibrium measure,
# and the ratio (paper_notes/performance.md, "Against a Newton solver").
BENCH_PEER_ARGS ?=
bench-peer: build peer-deps
	@mkdir -p $(RESULTS)
	$(PYTHON) experiments/peer/bench_peer.py --json $(RESULTS)/bench_peer.json $(BENCH_PEER_ARGS)

# The cost of one iteration (bench), then iterations to tolerance against mesh size, plain and
# Anderson, with the fitted growth exponents (bench_accel: Fig 5 K = 7 ... 112, the gutter at
# levels 1-3; 32 min on the shared 2-core machine at load 4-11). BENCH_QUICK=--quick skips the
# largest sizes.
BENCH_QUICK ?=
bench: build
	$(RUN)/bench $(BENCH_QUICK)
	OMP_NUM_THREADS=1 $(RUN)/bench_accel $(BENCH_QUICK)

# The global step's two solvers (Cholesky, CG + AMG with PETSc) on the refined gutters: setup,
# bytes, cost per ALG2 iteration, CG iterations, peak memory; and CHOLMOD's predicted factor of
# larger gutters without factorizing (paper_notes/performance.md, "Memory per cell, and CG + AMG").
BENCH_AMG_ARGS ?= --max-cells 40000 --predict 1000000
bench-amg: petsc-build
	$(PETSC_BUILD)/experiments/bench_amg $(BENCH_AMG_ARGS)

# Regenerate the stored reference data of the regression tests (review the diff).
reference: build
	$(BUILD)/tests/make_reference tests/reference/regression.toml

# Rewrites the key table of experiments/README.md from the configuration schema.
keys: build
	$(BUILD)/tests/key_table experiments/README.md

format:
	clang-format -i lib/*.cpp lib/*.hpp tests/*.cpp tests/*.hpp experiments/*.cpp experiments/*/*.cpp

clean:
	rm -rf $(BUILD) build-sanitize $(RESULTS)
