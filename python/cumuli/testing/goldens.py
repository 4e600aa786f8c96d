"""``assert_image_close``: a render against an array or a golden file kept by the user, with a
readable failure and the failure's images left on disk.

Where the goldens are rewritten and where failure images go is set by the pytest plugin
(``--cumuli-update-goldens``, ``--cumuli-failures``); outside pytest, by the environment variables
``CUMULI_UPDATE_GOLDENS=1`` and ``CUMULI_FAILURES`` (default ``_failures`` in the working folder).
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

import numpy as np

from cumuli.testing.compare import (
    ImageComparison,
    as_rgba,
    compare_images,
    current_test_name,
    write_failure_images,
)


class Settings:
    """Where goldens and failure images are handled (the plugin sets both per session)."""

    update_goldens: bool = os.environ.get("CUMULI_UPDATE_GOLDENS", "") == "1"
    failures_dir: Path = Path(os.environ.get("CUMULI_FAILURES", "_failures"))


def assert_image_close(
    actual: np.ndarray,
    expected: np.ndarray | str | os.PathLike[str],
    *,
    name: str | None = None,
    **tolerances: Any,
) -> ImageComparison:
    """Assert that ``actual`` matches ``expected`` within the tolerances of
    :func:`cumuli.testing.compare_images` (keyword arguments; its defaults otherwise).

    ``expected`` is an array, or the path of a golden image (``.exr`` keeps float values and
    alpha; ``.png`` is 8-bit). A golden that does not exist fails the test, saying how to write
    it; with ``pytest --cumuli-update-goldens`` the golden is (re)written from ``actual`` and the
    check passes. On failure ``<name>_actual.exr``, ``_expected.exr``, ``_diff.exr`` and
    ``_heat.png`` are written to the failures folder and the ``AssertionError`` names each failed
    metric with its value, its limit and the pixel where it is worst. ``name`` (default: the
    golden's stem, else the running test's id) names those files. Returns the comparison.
    """
    if isinstance(expected, (str, os.PathLike)):
        from cumuli.io.images import read_image, write_image

        golden = Path(expected)
        name = name or golden.stem
        if Settings.update_goldens:
            golden.parent.mkdir(parents=True, exist_ok=True)
            write_image(golden, as_rgba(actual), "keep")
        elif not golden.is_file():
            raise AssertionError(
                f"golden image {golden} does not exist; run pytest with "
                "--cumuli-update-goldens to write it from this render"
            )
        reference = read_image(golden)
        if np.asarray(actual).ndim == 3 and reference.shape[2] > np.asarray(actual).shape[2]:
            reference = reference[..., : np.asarray(actual).shape[2]]
        source = f"golden {golden}"
    else:
        reference, source = np.asarray(expected), "the expected array"
    if np.shape(actual) != np.shape(reference):
        raise AssertionError(
            f"actual image has shape {np.shape(actual)} but {source} has {np.shape(reference)}"
        )
    result = compare_images(actual, reference, **tolerances)
    if not result.ok:
        folder = Settings.failures_dir
        paths = write_failure_images(folder, name or current_test_name(), actual, reference)
        raise AssertionError(
            f"{result.report()}\n  against {source}; images written: "
            + ", ".join(p.name for p in paths)
            + f" in {folder}"
        )
    return result
