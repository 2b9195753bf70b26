PY ?= python3
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed
NODE_STAMP := $(VENV)/.node-installed
DOCS_STAMP := $(VENV)/.docs-installed

.PHONY: view-deps demo test check docs lint bench bench-imu bench-batch bench-clip sweep fuzz clean pg-start pg-stop mcu

# the C encoders (c/mkpla) are compiled into the package by pip (setup.py: cffi); a changed C source rebuilds
$(STAMP): pyproject.toml Makefile setup.py c/mkpla_cffi.py $(wildcard c/mkpla/*.c c/mkpla/*.h)
	$(PY) -m venv $(VENV)
	$(BIN)/python -m pip install -q --upgrade pip
	$(BIN)/python -m pip install -q -e '.[test,dev]'
	touch $(STAMP)

# the Khronos glTF validator is used by the tests only (skipped with a reason where node is missing);
# gltfpack (meshoptimizer) by benchmarks/gltfpack_anchor.py
$(NODE_STAMP): $(STAMP)
	@if command -v npm >/dev/null; then \
		npm install --prefix $(VENV)/node gltf-validator@2.0.0-dev.3.10 gltfpack@1.3.0 --no-audit --no-fund --silent && touch $(NODE_STAMP); \
	else echo "npm not found: the glTF validator tests will be skipped"; fi

# the viewer's browser tests run Debian's chromium (headless, driven by playwright with executable_path)
# and the --export tests Debian's ffmpeg; installed here when root with apt, else those tests skip with a reason
view-deps:
	@if [ -x /usr/bin/chromium ] && command -v ffmpeg >/dev/null; then :; \
	elif [ "$$(id -u)" = 0 ] && command -v apt-get >/dev/null; then \
		echo "installing chromium and ffmpeg (apt)"; \
		DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends chromium ffmpeg >/dev/null 2>&1 || \
		{ apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends chromium ffmpeg >/dev/null; }; \
	else echo "chromium/ffmpeg missing and not root: the viewer's browser and mp4 tests will be skipped"; fi

demo: $(STAMP)
	$(BIN)/mocapkit demo

# the whole suite, in parallel (one pytest-xdist worker per core; a file's tests stay on one worker, so
# its module fixtures are made once), hypothesis' thorough "ci" profile; docs/testing.md describes the
# markers, profiles and how to run one file
test: $(STAMP) $(NODE_STAMP) view-deps
	HYPOTHESIS_PROFILE=ci $(BIN)/python -m pytest -q -n auto --dist loadfile

# the edit loop (<= 90 s): the unit tests alone, hypothesis' quick "dev" profile; no real data, server,
# browser, cluster, MCU or node, no CLI/pipeline integration file; ruff and mypy first (make lint)
CHECK_MARKS := not shared and not slow and not integration and not browser and not pg and not dask and not mcu and not node
check: $(STAMP) lint
	HYPOTHESIS_PROFILE=dev $(BIN)/python -m pytest -q -n auto --dist loadfile -m "$(CHECK_MARKS)"

# Sphinx, furo and MyST (the [docs] extra), on top of the package
$(DOCS_STAMP): $(STAMP) pyproject.toml
	$(BIN)/python -m pip install -q -e '.[docs]'
	touch $(DOCS_STAMP)

# the documentation site into build/docs (open build/docs/index.html): the pages of docs/, the API from the
# docstrings of every name in the packages' __all__, the command reference from the typer app; any warning
# fails the build
docs: $(DOCS_STAMP)
	$(BIN)/python -m sphinx -W --keep-going -b html docs build/docs

# ruff (rules in pyproject.toml) over the code and mypy over src/mocapkit (strict on the public core)
lint: $(STAMP)
	$(BIN)/ruff check src tests benchmarks tools docs
	$(BIN)/mypy

bench: $(STAMP)
	$(BIN)/mocapkit bench --json > docs/bench.json

# peak memory of the IMU CSV reader on a generated 800 MB file (issue 10: <= 3x the numeric data)
bench-imu: $(STAMP)
	$(BIN)/python benchmarks/imu_memory.py

sweep: $(STAMP)
	$(BIN)/mocapkit sweep ../shared/data/imu/xio-lower-body --out docs/sweep

# mocapkit batch at scale: 1,000 generated recordings + 10 corrupt files, 1 vs 2 workers, Dask vs the
# local pool, main-process memory, catalog size and query time on DuckDB (and PostgreSQL when
# MOCAPKIT_TEST_PG names a server: make pg-start); needs ../shared/data; writes docs/batch_bench.json
bench-batch: $(STAMP)
	$(BIN)/python benchmarks/batch_scale.py --n 1000 --work build/batch-bench --json docs/batch_bench.json

# the .mkc clip against ACL's figures, encode speed against the previous path, decode / pose_at speed;
# needs ../shared/data; writes docs/clip_bench.json
bench-clip: $(STAMP)
	$(BIN)/python benchmarks/clip_bench.py --json docs/clip_bench.json

# the C encoders (c/mkpla) on a Cortex-M4 under QEMU (mps2-an386): points equal to the host float32
# build on ../shared/data's IMU recordings, executed instructions per sample, code size, RAM (-O3 as the
# fastSW paper; -O2 counted on the synthetic signals); needs arm-none-eabi-gcc, newlib, qemu-system-arm;
# writes docs/mcu.json
mcu: $(STAMP)
	$(BIN)/python tools/mcu_measure.py --opt=-O3 --compare-opt=-O2 --json docs/mcu.json

# issue 10's adversarial trial (tools/trial.py): mutated files of every format, odd output paths, extreme
# options, kill -9, huge claims; prints category x outcome counts, writes $(FUZZ_OUT)/report.md and .json,
# fails on any crash, hang, memory blow-up, wrong-but-silent result, modified input or replaced device
FUZZ_CASES ?= 5000
FUZZ_JOBS ?= 2
FUZZ_OUT ?= build/trial
fuzz: $(STAMP)
	$(BIN)/python tools/trial.py --cases $(FUZZ_CASES) --jobs $(FUZZ_JOBS) --out $(FUZZ_OUT)

# a throw-away PostgreSQL for the catalog tests (127.0.0.1:$$MOCAPKIT_PG_PORT, default 54329); then
#   export MOCAPKIT_TEST_PG=postgresql://postgres@127.0.0.1:54329/mocapkit_test   (printed by pg-start)
pg-start:
	tools/pg_test_server.sh install
	tools/pg_test_server.sh start

pg-stop:
	tools/pg_test_server.sh stop

clean:
	rm -rf $(VENV) build src/*.egg-info src/mocapkit/_mkpla*.so
	find src -name '*.nbi' -delete -o -name '*.nbc' -delete
