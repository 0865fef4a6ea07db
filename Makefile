# Quick start: `make test` (installs into .venv and runs the suite), `make demo` (runs the main job).
PYTHON ?= python3
VENV := .venv
PY := $(VENV)/bin/python
PIP := $(PY) -m pip
STAMP := $(VENV)/.installed
export MENAGERIE_ROOT ?= $(shell test -d ../shared/menagerie && cd ../shared/menagerie && pwd)

.PHONY: install test demo replay bench lint clean

install: $(STAMP)

# Order matters: CPU torch first (any other torch spec pulls CUDA wheels), then our package and its
# extras, then mushroom-rl and myo-sim without their pins (torch 2.5.1, numpy 1.24) so nothing gets downgraded.
$(STAMP): pyproject.toml
	test -d $(VENV) || $(PYTHON) -m venv $(VENV)
	$(PIP) install -q --upgrade pip
	$(PIP) install -q torch==2.13.0
	$(PIP) install -q -e ".[dev]"
	$(PIP) install -q --no-deps mushroom-rl==1.10.2
	# myo-sim pins mujoco<4 but its MJCF loads on mujoco 4; we only read its model files.
	$(PIP) install -q --no-deps myo-sim==0.2.4
	$(PY) -c "import torch, numpy; assert not torch.version.cuda, 'CUDA torch installed'; \
	  assert int(numpy.__version__.split('.')[0]) >= 2, 'numpy was downgraded'"
	touch $(STAMP)

# One pytest worker per CPU (pytest-xdist), each test file on one worker so that its module fixtures are built once.
TEST_WORKERS ?= auto
test: install
	$(PY) -m ruff check loco_mujoco baselines tests bench experiments
	$(PY) -m pytest -q -n $(TEST_WORKERS) --dist loadfile

# A short VAIL training on UnitreeH1.walk (2 min 3 s on 2 cores), then its evaluation against a random policy.
DEMO_STEPS ?= 500000
demo: install
	rm -rf out/demo_vail
	$(PY) experiments/launch.py --env UnitreeH1.walk --algo vail --steps $(DEMO_STEPS) --out out/demo_vail
	$(PY) experiments/evaluate.py out/demo_vail/checkpoint.pt

# Replay UnitreeH1.walk's real dataset, print its provenance and quality, write out/demo.mp4.
replay: install
	$(PY) -m loco_mujoco.demo

bench: install
	$(PY) bench/env_throughput.py

lint: install
	$(PY) -m ruff check loco_mujoco baselines tests bench experiments

clean:
	rm -rf $(VENV) .pytest_cache .ruff_cache *.egg-info
