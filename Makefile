# The front door. `make figures` reproduces every figure of the paper; `make test` runs the tests.
# Both install missing Debian packages first (as root; otherwise they print the command).
PYTHON  := /usr/bin/python3
BUILD   := build
RESULTS := results
JOBS    ?= 2
RUN     := $(BUILD)/experiments

.PHONY: all figures test bench deps build fig3 fig4 fig5 fig6 compare hertz reference format clean

all: figures

deps:
	@bash .ci/deps.sh

build: deps
	@cmake -S . -B $(BUILD) -DCMAKE_BUILD_TYPE=Release > /dev/null
	@cmake --build $(BUILD) -j $(JOBS)

test: build
	cd $(BUILD) && OMP_NUM_THREADS=2 ctest --output-on-failure -j $(JOBS)

figures: fig3 fig4 fig5 fig6

# One target per paper figure: run the driver (HDF5 in results/), then plot from the HDF5 only.
fig3 fig4 fig5 fig6: build
	@mkdir -p $(RESULTS)
	$(RUN)/$@ experiments/$@/$@.toml -o $(RESULTS)/$@.h5
	$(PYTHON) figures/$@.py $(RESULTS)/$@.h5 $(RESULTS)/$@.png

# Uzawa vs Bermudez-Moreno on every figure's problem, with sweeps of R and rho.
compare: build
	@mkdir -p $(RESULTS)/compare
	$(RUN)/compare $(RESULTS)/compare
	$(RUN)/hertz 2 0.1 0.75 $(RESULTS)/compare
	$(PYTHON) figures/compare.py $(RESULTS)/compare $(RESULTS)/compare.pdf

# Section 7: the Signorini solver against Hertz under mesh refinement, both updates.
hertz: build
	$(RUN)/hertz

bench: build
	$(RUN)/bench
	OMP_NUM_THREADS=1 $(RUN)/bench_accel --quick

# Regenerate the stored reference data of the regression tests (review the diff).
reference: build
	$(BUILD)/tests/make_reference tests/reference/regression.toml

format:
	clang-format -i lib/*.cpp lib/*.hpp tests/*.cpp experiments/*.cpp experiments/*/*.cpp

clean:
	rm -rf $(BUILD) $(RESULTS)
