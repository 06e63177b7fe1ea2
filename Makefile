# The front door. `make figures` reproduces every figure of the paper; `make test` runs the tests.
# Both install missing Debian packages first (as root; otherwise they print the command).
PYTHON  := /usr/bin/python3
BUILD   := build
RESULTS := results
JOBS    ?= 2
RUN     := $(BUILD)/experiments

.PHONY: all figures test bench deps build fig3 fig4 fig5 fig6 compare hertz readings reference format \
	clean

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
	$(RUN)/$@ experiments/$@/$@_literal.toml -o $(RESULTS)/$@_literal.h5
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

bench: build
	$(RUN)/bench

# Regenerate the stored reference data of the regression tests (review the diff).
reference: build
	$(BUILD)/tests/make_reference tests/reference/regression.toml

format:
	clang-format -i lib/*.cpp lib/*.hpp tests/*.cpp experiments/*.cpp experiments/*/*.cpp

clean:
	rm -rf $(BUILD) $(RESULTS)
