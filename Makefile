PY ?= python3
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed

.PHONY: demo test bench sweep clean

$(STAMP): pyproject.toml Makefile
	$(PY) -m venv $(VENV)
	$(BIN)/python -m pip install -q --upgrade pip
	$(BIN)/python -m pip install -q -e '.[test]'
	npm install --prefix $(VENV)/node gltf-validator@2.0.0-dev.3.10 --no-audit --no-fund --silent
	touch $(STAMP)

demo: $(STAMP)
	$(BIN)/mocapkit demo

test: $(STAMP)
	$(BIN)/python -m pytest -q

bench: $(STAMP)
	$(BIN)/mocapkit bench --json > docs/bench.json

sweep: $(STAMP)
	$(BIN)/mocapkit sweep ../shared/data/imu/xio-lower-body --out docs/sweep

clean:
	rm -rf $(VENV) build src/*.egg-info
	find src -name '*.nbi' -delete -o -name '*.nbc' -delete
