# The two commands: `make run` (the simulator on its built-in default scene) and `make test`.
# Each creates .venv from PyPI when it is missing (no apt ROS install needed), with the exact versions
# pinned in requirements.lock, and installs this package into it (editable), so every console script
# is in .venv/bin. `make lock` re-resolves the pins from requirements*.txt on purpose, then tests.
PYTHON ?= python3
VENV := .venv
PY := $(VENV)/bin/python
PIP := $(PY) -m pip --disable-pip-version-check

.PHONY: run test docs lock reference bench bench-exact bench-effects bench-plant bench-campaign bench-node bench-bag bench-bag-day bench-lockstep bench-testing-kit bench-sensors bench-wheels bench-environment clean

$(VENV)/.installed: requirements.txt requirements-test.txt requirements.lock setup.py
	test -x $(PY) || $(PYTHON) -m venv $(VENV)
	$(PIP) install --quiet -c requirements.lock -r requirements-test.txt
	$(PIP) install --quiet --no-deps --no-build-isolation -e .
	touch $@

# The TypeScript compiler (npm, beside the virtualenv) that test/test_launch_and_views.py checks the
# Foxglove/Lichtblick layout's user script with, as the apps do; node.js and npm are the machine's.
TYPESCRIPT := $(VENV)/npm/node_modules/typescript/package.json

$(TYPESCRIPT):
	npm install --silent --no-audit --no-fund --save-exact --prefix $(VENV)/npm typescript@5.3.3

run: $(VENV)/.installed
	$(VENV)/bin/torquefree_sim $(if $(ARGS),--ros-args $(ARGS))

test: $(VENV)/.installed $(TYPESCRIPT)
	$(PY) -m coverage run -m pytest
	$(PY) -m coverage report

# the API reference (Sphinx, warnings as errors; test/test_docs.py builds it too): docs/api/_build/html/index.html
docs: $(VENV)/.installed
	$(VENV)/bin/sphinx-build -W --keep-going -b html docs/api docs/api/_build/html

# Newest versions allowed by requirements*.txt, written to requirements.lock, then the tests on them.
lock:
	rm -rf $(VENV) .venv-lock
	$(PYTHON) -m venv .venv-lock
	sed '/^-c /d' requirements-test.txt > .venv-lock/requirements-test.txt  # the same list, without the old pins
	cp requirements.txt .venv-lock/
	.venv-lock/bin/pip install --quiet --disable-pip-version-check -r .venv-lock/requirements-test.txt
	{ echo "# Exact versions for requirements-test.txt (which includes requirements.txt), resolved by"; \
	  echo "# 'make lock' on $$(date -u +%Y-%m-%d) with $$(.venv-lock/bin/python --version)."; \
	  .venv-lock/bin/pip freeze --all | grep -v -E '^(pip|torquefree[-_]ros)[= @]'; } > requirements.lock
	rm -rf .venv-lock
	$(MAKE) test

reference: $(VENV)/.installed
	$(PY) tools/make_reference.py --jobs 2

# the work-precision report: docs/bench/{work_precision.csv,work_precision.png,results.md}
bench: $(VENV)/.installed
	$(VENV)/bin/torquefree_bench --output-dir docs/bench

# the exact propagator's cost per sample (beside scipy's ellipj), per block, to build; propagate_batch
bench-exact: $(VENV)/.installed
	$(PY) tools/bench_exact.py --output docs/bench/exact.md

# scenes with motion effects: the compiled path beside the reference path and cyrk (~30 s; cyrk comes
# with the test requirements, as the bench extra's)
bench-effects: $(VENV)/.installed
	$(PY) tools/bench_effects.py --output docs/bench/effects.md

# the plant (torquefree_ros.Plant): a step of one body, a batched step, 1 000 dispersed explorer1 bodies
bench-plant: $(VENV)/.installed
	$(PY) tools/bench_plant.py --output docs/bench/plant.md

# the reaction wheels beside a constant torque: propagation, the plant, lock-step
bench-wheels: $(VENV)/.installed
	$(PY) tools/bench_wheels.py --output docs/bench/wheels.md

# the environment: its models per evaluation, the bdot_detumble scene stepped one sample at a time
# beside the same body under a constant torque (~1.5 min)
bench-environment: $(VENV)/.installed
	$(PY) tools/bench_environment.py --output docs/bench/environment.md

# the sensor models: the full gyro per sample against the white-noise imu, 1 000 bodies with every
# sensor at its full model (~3 min)
bench-sensors: $(VENV)/.installed
	$(PY) tools/bench_sensors.py --output docs/bench/sensors.md

# Monte Carlo campaigns: 10 000 torque-free runs on 1 and 2 local workers beside the bare compute,
# 1 000 dispersed explorer1 runs, the engine's costs (~1 min)
bench-campaign: $(VENV)/.installed
	$(PY) tools/bench_campaign.py --rounds 5 --output docs/bench/campaign.md

bench-node: $(VENV)/.installed
	$(PY) tools/bench_node.py --output docs/bench/node.md

# closed loop: lock-step round trips with a controller in another process, and the cost of a step
bench-lockstep: $(VENV)/.installed
	$(PY) tools/bench_lockstep.py --output docs/bench/lockstep.md

# the test kit (torquefree_ros.testing): set-up, teardown and advance(1), beside rclpy's round trip
bench-testing-kit: $(VENV)/.installed
	$(PY) tools/bench_testing_kit.py --output docs/bench/testing_kit.md

bench-bag: $(VENV)/.installed
	$(PY) tools/bench_bag.py --output docs/bench/bag.md

# peak memory of one 24 h bag at 1 kHz (~20 min, ~15 GB in the temporary directory)
bench-bag-day: $(VENV)/.installed
	$(PY) tools/bench_bag.py --day --output docs/bench/bag_day.md

clean:
	rm -rf $(VENV) .venv-lock build install log
