# The two commands of the README. Each creates .venv and installs on first use.
PY ?= python3
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed

.PHONY: run test reproduce bench clean

$(STAMP): pyproject.toml
	$(PY) -m venv $(VENV)
	$(BIN)/python -m pip install -q --upgrade pip
	# CPU build first: an unpinned torch would pull several GB of CUDA packages.
	$(BIN)/python -m pip install -q torch==2.13.0
	$(BIN)/python -m pip install -q -e ".[dev]"
	touch $(STAMP)

run: $(STAMP)
	$(BIN)/python train.py

reproduce: $(STAMP)
	$(BIN)/python -m planetnav_env.reproduce angular-size --plots results/angular_size --json results/angular_size.json
	$(BIN)/python -m planetnav_env.reproduce optical-pulsar --plots results/optical_pulsar --json results/optical_pulsar.json
	$(BIN)/python -m planetnav_env.reproduce gnss-magnetometer --plots results/gnss_magnetometer --json results/gnss_magnetometer.json

test: $(STAMP)
	$(BIN)/ruff check .
	$(BIN)/python -m pytest

bench: $(STAMP)
	$(BIN)/python benchmarks/bench_core.py
	$(BIN)/python benchmarks/bench_env.py
	$(BIN)/python benchmarks/bench_vec.py
	$(BIN)/python benchmarks/bench_gnss.py

clean:
	rm -rf $(VENV) results runs
