# The two commands of the README. Each creates .venv and installs on first use.
PY ?= python3
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed

.PHONY: run precompile test test-ray test-ray-all reproduce bench bench-ray device-wheels clean

$(STAMP): pyproject.toml
	$(PY) -m venv $(VENV)
	$(BIN)/python -m pip install -q --upgrade pip
	# CPU build first: an unpinned torch would pull several GB of CUDA packages.
	$(BIN)/python -m pip install -q torch==2.13.0
	# setuptools warns on every editable install of a package mapped to another folder (planetnav_agents
	# lives in agents/), about folders named like the package in the working directory: this tree has none.
	PYTHONWARNINGS="ignore:Editable installation" $(BIN)/python -m pip install -q -e ".[dev]"
	touch $(STAMP)

# Second environment with the [ray] extra (RLlib + Tune). RLlib pins gymnasium (1.2.2 for ray 2.60), so
# this one also checks planetnav under that gymnasium, while .venv keeps the default (newest) one.
# It also holds the [clients] extra (torchrl 0.14 + tensordict 0.14, sb3-contrib), which the optional
# tests/test_client_*.py run against; both install for torch 2.13.0 and leave it as it is (~5 MB).
RAY_VENV := .venv-ray
RAY_BIN := $(RAY_VENV)/bin
RAY_STAMP := $(RAY_VENV)/.installed

$(RAY_STAMP): pyproject.toml
	$(PY) -m venv $(RAY_VENV)
	$(RAY_BIN)/python -m pip install -q --upgrade pip
	$(RAY_BIN)/python -m pip install -q torch==2.13.0
	PYTHONWARNINGS="ignore:Editable installation" $(RAY_BIN)/python -m pip install -q -e ".[dev,ray,clients]"
	touch $(RAY_STAMP)

run: $(STAMP)
	$(BIN)/python train.py

reproduce: $(STAMP)
	$(BIN)/python -m planetnav_validation.reproduce angular-size --plots results/angular_size --json results/angular_size.json
	$(BIN)/python -m planetnav_validation.reproduce optical-pulsar --plots results/optical_pulsar --json results/optical_pulsar.json
	$(BIN)/python -m planetnav_validation.reproduce gnss-magnetometer --plots results/gnss_magnetometer --json results/gnss_magnetometer.json

# Two pytest processes at once, one per core: SPLIT_TESTS (the row kernels compiled to PTX and as the
# device's thread functions: about a third of the suite's time, nearly all of it numba compiling) beside the
# rest. Its output follows the rest's, and the target fails if either fails.
SPLIT_TESTS := tests/env/test_cuda_ptx.py
# numba's cache is filled first (planetnav_env.precompile), so that the test processes load the kernels
# rather than several compile them at once: the step, and beside it the device env's host mode. SPLIT_TESTS
# starts once the step is cached (its thread-function tests come last, by when the host mode is too); the
# rest, and whoever waits for .test-compiled (.ci/run's [ray] pass), once both are.
test: $(STAMP)
	$(BIN)/ruff check .
	@rm -f .test-compiled; \
	$(BIN)/python -m planetnav_env.precompile --host-mode --quiet & host=$$!; \
	$(BIN)/python -m planetnav_env.precompile --quiet || { wait $$host; touch .test-compiled; exit 1; }; \
	$(BIN)/python -m pytest $(SPLIT_TESTS) > .test-split.log 2>&1 & split=$$!; \
	wait $$host; compiled=$$?; touch .test-compiled; \
	if [ $$compiled -ne 0 ]; then wait $$split; exit 1; fi; \
	$(BIN)/python -m pytest --ignore=$(SPLIT_TESTS); rest=$$?; \
	wait $$split; other=$$?; \
	echo "===== $(SPLIT_TESTS) (rc $$other) ====="; cat .test-split.log; \
	[ $$rest -eq 0 ] && [ $$other -eq 0 ]

# numba's cache for the step (every id) and for the device env's host mode, one process each.
precompile: $(STAMP)
	@$(BIN)/python -m planetnav_env.precompile --quiet & step=$$!; \
	$(BIN)/python -m planetnav_env.precompile --host-mode --quiet; host=$$?; \
	wait $$step && [ $$host -eq 0 ]

# Under the [ray] extra's gymnasium (the one RLlib pins): the Ray tests (two-node loopback clusters, RLlib
# training and resume, Tune sweeps, node loss), the client tests (TorchRL, sb3-contrib) that the default
# environment skips, and everything that touches Gymnasium's API: the environment package's tests (checkers,
# seeding, vector env, golden hashes), the training envs and the environment without torch. The rest ran in
# `make test` already (tests/project's import graph and packaging read the source and build a wheel with the
# same pip and setuptools), as did the CPU-settings reruns of the golden tests. RAY_SAME are the environment
# package's tests that cannot differ here: pure physics and numerics that import neither gymnasium nor
# planetnav_env.envs (tests/project/test_ci_split.py holds that, through every module they import), and every
# other package they use is the same version in both environments. A new test file under tests/env runs here
# until it is listed. tests/validation (the reproductions, harnesses and oracles) does not run here: it reaches
# no gymnasium either (test_ci_split.py holds that too). `make test-ray-all` runs the whole suite there.
# tests/rl runs last: its drivers, env runners and trials are processes of their own, and by then the
# tests before them have written numba's cache, so they load the kernels instead of compiling them cold.
RAY_TESTS := tests/env tests/train/test_client_sb3_contrib.py tests/train/test_training_golden.py \
	tests/train/test_vec_training.py tests/project/test_install_extras.py tests/rl
RAY_SAME := apparent approach attitude camera config_options core_ephemeris core_rng device_occupancy \
	cuda_ptx device_preflight disturbances ekf ephemeris ephemeris_velocity figure gauss_markov measurements numba_cache \
	orbit photometry pointing pulsar quaternion same_numbers star_fix_kernels star_tracker thrust_gauss_markov wahba

test-ray: $(RAY_STAMP)
	RAY_ENABLE_WINDOWS_OR_OSX_CLUSTER=0 $(RAY_BIN)/python -m pytest -m "not cpu_settings" $(RAY_TESTS) \
		$(RAY_SAME:%=--ignore=tests/env/test_%.py)

test-ray-all: $(RAY_STAMP)
	RAY_ENABLE_WINDOWS_OR_OSX_CLUSTER=0 $(RAY_BIN)/python -m pytest -m "not cpu_settings"

bench-ray: $(RAY_STAMP)
	RAY_ENABLE_WINDOWS_OR_OSX_CLUSTER=0 $(RAY_BIN)/python benchmarks/bench_ray.py

bench: $(STAMP)
	$(BIN)/python benchmarks/bench_core.py
	$(BIN)/python benchmarks/bench_env.py
	$(BIN)/python benchmarks/bench_vec.py
	$(BIN)/python benchmarks/bench_gnss.py

# The pure-Python packages a lent GPU machine's image lacks, as wheels for benchmarks/device_check.sh (it
# installs them there without the network): the versions this machine's .venv holds.
DEVICE_WHEELS := gymnasium farama-notifications filterpy jplephem skyfield-data
device-wheels: $(STAMP)
	mkdir -p .whl
	$(BIN)/python -m pip download -q --no-deps -d .whl \
		$$(for p in $(DEVICE_WHEELS); do echo "$$p==$$($(BIN)/python -m pip show $$p | sed -n 's/^Version: //p')"; done)

clean:
	rm -rf $(VENV) $(RAY_VENV) results runs
