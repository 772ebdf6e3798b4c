# Two commands matter: `make demo` and `make test`. Each sets everything up on a
# fresh machine (Debian libllvm19 when missing, Debian chromium for the report's
# browser test when missing, a .venv with labcut installed editable with its test
# extras) and is idempotent.

PYTHON ?= python3
VENV   := .venv
BIN    := $(VENV)/bin
STAMP  := $(VENV)/.labcut-installed
OUT    ?= out/demo
PYTEST_WORKERS ?= 2
# more pytest options, e.g. PYTEST_ARGS=--durations=30
PYTEST_ARGS ?=

.PHONY: setup llvm chromium demo test mutation clean help

help:
	@echo "make demo   set up, then run the main job on a bundled stone"
	@echo "make test   set up, then run the test suite"

llvm:
	@bash tools/ensure-llvm.sh

chromium:
	@bash tools/ensure-chromium.sh

$(STAMP): pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -e '.[test]'
	@touch $(STAMP)

setup: llvm chromium $(STAMP)

demo: setup
	@mkdir -p $(OUT)
	$(BIN)/labcut spectrum --preset blue --plot $(OUT)/spectrum-blue.png --json $(OUT)/spectrum-blue.json
	$(BIN)/labcut recommend-orientation meshes/oval-16x12-low.ply --preset blue --scenario bench \
		--json $(OUT)/oval-bench.json --render $(OUT)/oval-bench.png --map $(OUT)/oval-bench-map.png
	$(BIN)/labcut recommend-orientation meshes/oval-16x12-low.ply --preset blue --scenario pendant --variants 6 \
		--json $(OUT)/oval-pendant.json --render $(OUT)/oval-pendant.png --map $(OUT)/oval-pendant-map.png
	$(BIN)/labcut recommend-orientation meshes/carving-biplane.ply --preset blue --scenario bench \
		--json $(OUT)/biplane-bench.json --render $(OUT)/biplane-bench.png --map $(OUT)/biplane-bench-map.png
	$(BIN)/labcut compare meshes/oval-16x12-low.ply meshes/oval-16x12-medium.ply meshes/oval-16x12-high.ply \
		--preset blue --scenario bench --scenario pendant --quality draft \
		--html $(OUT)/compare.html --json $(OUT)/compare.json --csv $(OUT)/compare.csv
	$(BIN)/labcut rough meshes/rough/nodule-convex.ply --flash-tilt 30 --flash-azimuth 60 --count 2 --quality draft \
		--preset blue --json $(OUT)/rough-plan.json --html $(OUT)/rough-plan.html --png $(OUT)/rough-plan.png
	rm -rf $(OUT)/batch.parquet
	$(BIN)/labcut batch examples/catalog-demo.csv --quality draft --out $(OUT)/batch.parquet --html $(OUT)/batch.html
	@echo "demo outputs in $(OUT)/"

test: setup
	$(BIN)/python -m pytest -q -n $(PYTEST_WORKERS) --dist worksteal $(PYTEST_ARGS) tests

# Mutation testing of one module against its own tests (issue 37; not part of `make test`):
# make mutation MODULE=labcut/physics/lamella.py   (docs/testing.md)
MODULE ?=
mutation: setup
	$(BIN)/python -m pip install --quiet -e '.[test,mutation]'
	$(BIN)/python tools/mutation.py $(MODULE)

clean:
	rm -rf $(VENV) out .pytest_cache .hypothesis
