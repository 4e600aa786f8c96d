"""Checks of renders for pytest suites, the package's own and its users'.

Loaded by pytest automatically once cumuli is installed (a ``pytest11`` entry point), it brings:

- :func:`assert_image_close` — a render against an array or a golden image, with per-pixel and
  block metrics and a failure that says where, how much and by which metric;
- ``pytest --cumuli-update-goldens`` to (re)write the golden images from the current renders,
  and ``--cumuli-failures DIR`` (or the ini option ``cumuli_failures``) for the actual, expected,
  difference and heat-map images a failed comparison writes;
- the ``gl`` marker: tests marked with it skip, with the reason, where no headless OpenGL
  context can be made;
- the ``gl_context`` fixture: one ``cumuli.gl.GLContext`` for the session.
"""

from __future__ import annotations

from cumuli.testing.compare import (
    DEFAULTS,
    ImageComparison,
    cell_pattern_energy,
    compare_images,
    heat_map,
    only,
)
from cumuli.testing.goldens import assert_image_close
from cumuli.testing.plugin import (
    gl_context,
    pytest_addoption,
    pytest_collection_modifyitems,
    pytest_configure,
    pytest_report_header,
)

__all__ = [
    "DEFAULTS",
    "ImageComparison",
    "assert_image_close",
    "cell_pattern_energy",
    "compare_images",
    "gl_context",
    "heat_map",
    "only",
]
__all__ += [
    "pytest_addoption",
    "pytest_collection_modifyitems",
    "pytest_configure",
    "pytest_report_header",
]
