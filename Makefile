# Footstep Planner: development tasks.
#   make test      run the test suite (PYTEST_ARGS="-k foo -x" to pass extra args)
#   make demo      run the demo (SCENE=name to pick a sample scene)
#   make build     build the extension zips into dist/ (PLATFORMS=linux-x64,... to restrict)
#   make clean     remove build outputs and caches (distclean: also wheels/ and .venv/)

PYTHON ?= python3
VENV := .venv
VENV_PY := $(VENV)/bin/python
VENV_STAMP := $(VENV)/.installed

PYTEST_ARGS ?=
# test processes (pytest-xdist): one per core; TEST_JOBS=0 runs them in this process
TEST_JOBS ?= auto
SCENE ?=
PLATFORMS ?=
BUILD_ARGS ?=

.PHONY: venv test demo build clean distclean

# The venv is (re)installed whenever requirements.txt changes.
$(VENV_STAMP): requirements.txt
	@$(PYTHON) -c 'import sys; sys.exit(0 if sys.version_info[:2] == (3, 11) else "error: Python 3.11 is required (bpy 5.0.1 is cp311 only); got " + sys.version.split()[0] + " from $(PYTHON). Use make PYTHON=python3.11")'
	@test -x $(VENV_PY) || $(PYTHON) -m venv $(VENV) || { \
	  echo "error: '$(PYTHON) -m venv' failed; on Debian/Ubuntu install the python3-venv package" >&2; \
	  rm -rf $(VENV); exit 1; }
	$(VENV_PY) -m pip install -r requirements.txt
	touch $@

$(VENV): $(VENV_STAMP)

venv: $(VENV_STAMP)

test: $(VENV_STAMP)
	$(VENV_PY) -m pytest -q -n $(TEST_JOBS) --dist loadfile tests $(PYTEST_ARGS)

demo: $(VENV_STAMP)
	$(VENV_PY) -m footstep_planner demo --out sample_scenes/out $(if $(SCENE),--scene $(SCENE))

build: $(VENV_STAMP)
	$(VENV_PY) tools/build_extension.py $(if $(PLATFORMS),--platforms $(PLATFORMS)) $(BUILD_ARGS)

clean:
	rm -rf dist build .pytest_cache .hypothesis
	find . -path ./$(VENV) -prune -o -name __pycache__ -type d -prune -exec rm -rf {} +

distclean: clean
	rm -rf wheels $(VENV)
