# Two commands on a fresh machine (see README):  make run  /  make test
# Each creates or refreshes the project venv (.venv) on first use.
PYTHON ?= python3
VENV   := .venv
BIN    := $(VENV)/bin
STAMP  := $(VENV)/.installed
# `make run` is the main job: paper 1's headline experiment (README); ARGS="--list" etc. for others
ARGS   ?= sighting_land_vehicle --mode container --jobs 2
PKGS   := gimbal_kinematics gimbal_sim gimbal_control gimbal_estimators
SETUPS := $(foreach p,$(PKGS),src/$(p)/setup.py src/$(p)/setup.cfg src/$(p)/package.xml)

export ROS_AUTOMATIC_DISCOVERY_RANGE ?= LOCALHOST

.PHONY: run test venv clean-venv

venv: $(STAMP)

$(STAMP): requirements.txt $(SETUPS)
	test -x $(BIN)/python || $(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --disable-pip-version-check -r requirements.txt
	$(BIN)/python -m pip install --quiet --disable-pip-version-check --no-deps --no-build-isolation \
		$(foreach p,$(PKGS),-e src/$(p))
	@# setup.cfg puts executables where `ros2 run` looks ($$prefix/lib/<pkg>/); link them onto PATH too
	for exe in $(foreach p,$(PKGS),$(VENV)/lib/$(p)/*); do [ -f "$$exe" ] && ln -sf "$$(realpath $$exe)" $(BIN)/ || true; done
	touch $(STAMP)

run: $(STAMP)
	$(BIN)/gimbal-run $(ARGS)

# The suite runs on one worker more than the cores, up to 4 (pytest-xdist), a test file to a
# worker so that a module's recorded run is made once: many tests wait on node processes and
# subprocesses, which leaves a core idle. TEST_JOBS=0 runs it in this process. The 15 slowest
# tests are listed at the end.
TEST_JOBS ?= $(shell n=$$(nproc 2>/dev/null || echo 1); n=$$((n + 1)); [ $$n -gt 4 ] && n=4; echo $$n)

test: $(STAMP)
	$(BIN)/python -m pytest -n $(TEST_JOBS) --dist loadfile --durations=15 $(PYTEST_ARGS)

clean-venv:
	rm -rf $(VENV)
