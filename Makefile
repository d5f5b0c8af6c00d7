# Footstep Planner: development tasks.
#   make test      run the test suite (PYTEST_ARGS="-k foo -x" to pass extra args)
#   make test-lts  run the tests that touch Blender's API on Blender 4.5 LTS (own venv: .venv-lts)
#   make demo      run the demo (SCENE=name to pick a sample scene)
#   make build     build the extension zips and their .sha256 into dist/ (PLATFORMS=linux-x64,... to
#                  restrict); needs only Python 3.11 and pip, and validates with Blender's tool when
#                  the dev venv (bpy) is there
#   make clean     remove build outputs and caches (distclean: also wheels/, .venv/ and .venv-lts/)

PYTHON ?= python3
VENV := .venv
VENV_PY := $(VENV)/bin/python
VENV_STAMP := $(VENV)/.installed

LTS_VENV := .venv-lts
LTS_PY := $(LTS_VENV)/bin/python
LTS_STAMP := $(LTS_VENV)/.installed
# The tests that touch Blender's API (import, bake, Rigify, operators, extension build),
# run on bpy 4.5 LTS as well: a subset that takes 1 min 30 s on two cores (its venv made).
LTS_TESTS ?= tests/blender/test_blender_versions.py tests/blender/command/test_extension_build.py tests/blender/ui/test_panel_and_operators.py \
  tests/blender/ui/test_operators_behave.py \
  tests/blender/bake/test_bake.py tests/blender/rigify/test_rigify.py tests/blender/rigify/test_rigify_character.py tests/blender/read/test_clip_import.py \
  tests/blender/read/test_import_formats.py tests/blender/read/test_fbx_import.py tests/blender/command/test_cli.py tests/blender/sample/test_mannequin.py tests/core/report/test_overlay.py \
  tests/blender/bake/test_shared_shot.py tests/blender/ui/test_bake_together.py tests/blender/ui/test_give_way.py \
  tests/blender/ui/test_live.py tests/blender/bake/test_corners.py tests/blender/bake/test_jog.py

PYTEST_ARGS ?=
# test processes (pytest-xdist): one per core; TEST_JOBS=0 runs them in this process
TEST_JOBS ?= auto
# one BLAS thread a test process (the processes fill the cores; OpenBLAS's own threads on
# top spun: 40 million context switches and 144 s of system time a run, now 0.4 million, 19 s)
TEST_ENV := OPENBLAS_NUM_THREADS=1 OMP_NUM_THREADS=1
# The project's bytecode is compiled before the tests: where PYTHONDONTWRITEBYTECODE is set (as
# on the machines CI runs on) nothing else writes it, and each of the suite's sixty-odd
# Python processes compiled the package's 28,000 lines again, 0.3 to 0.5 s apiece.
COMPILE := $(VENV_PY) -m compileall -q -j 0 footstep_planner tests benchmarks > /dev/null
SCENE ?=
PLATFORMS ?=
BUILD_ARGS ?=

.PHONY: venv test test-lts demo build clean distclean

# make_venv(dir, requirements): a Python 3.11 venv in dir with requirements installed
define make_venv
	@$(PYTHON) -c 'import sys; sys.exit(0 if sys.version_info[:2] == (3, 11) else "error: Python 3.11 is required (bpy is cp311 only); got " + sys.version.split()[0] + " from $(PYTHON). Use make PYTHON=python3.11")'
	@test -x $(1)/bin/python || $(PYTHON) -m venv $(1) || { \
	  echo "error: '$(PYTHON) -m venv' failed; on Debian/Ubuntu install the python3-venv package" >&2; \
	  rm -rf $(1); exit 1; }
	$(1)/bin/python -m pip install -r $(2)
	touch $(1)/.installed
endef

# Each venv is (re)installed whenever its requirements change.
$(VENV_STAMP): requirements.txt
	$(call make_venv,$(VENV),requirements.txt)

$(LTS_STAMP): requirements-lts.txt
	$(call make_venv,$(LTS_VENV),requirements-lts.txt)

$(VENV): $(VENV_STAMP)

venv: $(VENV_STAMP)

test: $(VENV_STAMP)
	@$(COMPILE)
	$(TEST_ENV) $(VENV_PY) -m pytest -q -n $(TEST_JOBS) --dist loadfile tests $(PYTEST_ARGS)

test-lts: $(LTS_STAMP)
	$(LTS_PY) -c 'import bpy; print("Blender", bpy.app.version_string)'
	@$(subst $(VENV_PY),$(LTS_PY),$(COMPILE))
	$(TEST_ENV) $(LTS_PY) -m pytest -q -n $(TEST_JOBS) --dist loadfile $(LTS_TESTS) $(PYTEST_ARGS)

demo: $(VENV_STAMP)
	$(VENV_PY) -m footstep_planner demo --out sample_scenes/out $(if $(SCENE),--scene $(SCENE))

# No venv needed: the dev venv's Python when there is one (its bpy validates the zips), else $(PYTHON)
BUILD_PY = $(if $(wildcard $(VENV_PY)),$(VENV_PY),$(PYTHON))

build:
	@$(BUILD_PY) -c 'import sys; sys.exit(0 if sys.version_info[:2] >= (3, 11) else "error: the build needs Python 3.11 or later; got " + sys.version.split()[0] + " from $(BUILD_PY). Use make PYTHON=python3.11")'
	@$(BUILD_PY) -m pip --version >/dev/null 2>&1 || { echo "error: the build needs pip in $(BUILD_PY) (python3 -m ensurepip, or the python3-pip package)" >&2; exit 1; }
	$(BUILD_PY) tools/build_extension.py $(if $(PLATFORMS),--platforms $(PLATFORMS)) $(BUILD_ARGS)

clean:
	rm -rf dist build .pytest_cache .hypothesis
	find . -path ./$(VENV) -prune -o -path ./$(LTS_VENV) -prune -o -name __pycache__ -type d -prune -exec rm -rf {} +

distclean: clean
	rm -rf wheels $(VENV) $(LTS_VENV)
