# The two commands: `make run` (the simulator on its built-in default scene) and `make test`.
# Each creates .venv from PyPI when it is missing (no apt ROS install needed).
PYTHON ?= python3
VENV := .venv
PY := $(VENV)/bin/python

.PHONY: run test reference bench bench-node bench-bag clean

$(VENV)/.installed: requirements.txt requirements-test.txt
	test -x $(PY) || $(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --disable-pip-version-check -r requirements-test.txt
	touch $@

run: $(VENV)/.installed
	$(PY) -m torquefree_ros.sim_node $(if $(ARGS),--ros-args $(ARGS))

test: $(VENV)/.installed
	$(PY) -m pytest

reference: $(VENV)/.installed
	$(PY) tools/make_reference.py --jobs 2

# the work-precision report: docs/bench/{work_precision.csv,work_precision.png,results.md} (~15 min)
bench: $(VENV)/.installed
	$(PY) -m torquefree_ros.bench.cli --output-dir docs/bench

bench-node: $(VENV)/.installed
	$(PY) tools/bench_node.py

bench-bag: $(VENV)/.installed
	$(PY) tools/bench_bag.py

clean:
	rm -rf $(VENV) build install log
