# One command per habit; CI runs exactly these.
SHELL := /bin/bash
PYTHON ?= python3
UV := $(PYTHON) -m uv
RUN := $(UV) run --frozen --all-packages
UV_VERSION := 0.13.9

.PHONY: install vulkan chromium up test test-fast lint format bench soak clean

# --compile-bytecode: every process imports from .pyc even where PYTHONDONTWRITEBYTECODE is
# set (it is on the CI machine): torch + PyG then import in ~5 s instead of ~11 s.
install:  ## install uv and every package of the workspace (uv.lock), compiled to bytecode
	@$(PYTHON) -m uv --version >/dev/null 2>&1 || $(PYTHON) -m pip install --quiet "uv==$(UV_VERSION)"
	@$(UV) sync --frozen --all-packages --compile-bytecode

vulkan:  ## Debian 12 only, as root: Mesa 25 lavapipe for physics videos and ManiSkill rendering
	bash scripts/install-vulkan.sh

chromium:  ## Debian, as root: Chromium for the demonstration page's browser test
	bash scripts/install-chromium.sh

up: install  ## run a 4-block stacking episode through router, sim, planner and skills
	$(RUN) manigraph up --task stack --blocks 4 --episodes 1 --seed 0 --record logs/make-up.mcap

test: install lint  ## lint, then every test tier
	$(RUN) pytest -q -ra

test-fast: install  ## unit tests only
	$(RUN) pytest -q -m "not integration and not docker"

lint: install  ## ruff, mypy, and this branch's commit subjects (CONTRIBUTING.md)
	$(RUN) python scripts/check_commit_subjects.py
	$(RUN) ruff check .
	$(RUN) ruff format --check .
	$(RUN) mypy shared/manigraph_shared tools/manigraph_tools lab/manigraph_lab \
		services/sim/manigraph_sim services/planner/manigraph_planner \
		training/manigraph_training \
		services/skills/manigraph_skills services/perception/manigraph_perception \
		testkit/manigraph_testkit families/blocks/manigraph_blocks \
		families/dishwasher/manigraph_dishwasher families/shelf/manigraph_shelf

format: install
	$(RUN) ruff format .
	$(RUN) ruff check --fix .

bench: install  ## speed figures (not tests): medians and ratios
	$(RUN) python bench/bench_roundtrip.py
	$(RUN) python bench/bench_tls_roundtrip.py
	$(RUN) python bench/bench_startup.py
	$(RUN) python bench/bench_recorder.py
	$(RUN) python bench/bench_foxglove.py
	$(RUN) python bench/bench_policy_inference.py
	$(RUN) python bench/bench_training.py
	$(RUN) python bench/bench_eval.py
	$(RUN) python bench/bench_explainer.py
	$(RUN) python bench/bench_ik.py
	$(RUN) python bench/bench_physics.py
	$(RUN) python bench/bench_estop.py --busy 20
	$(RUN) python bench/bench_cells.py
	$(RUN) python bench/bench_ray_suite.py
	$(RUN) python bench/bench_training.py --device cuda

soak: install  ## one stack, one run (~45 min): 100k fuzzed payloads per key, floods, explain bomb, 3 episodes
	$(RUN) python bench/soak.py --json logs/soak.json

clean:
	rm -rf .venv logs .pytest_cache .ruff_cache .mypy_cache
