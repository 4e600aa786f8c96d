"""Light grids as values (Jiménez de Parga & Gómez Palomo 2018, §3.5): what a grid is, what it
was made from, and its files.

:class:`LightParams` is the one home of the NDT light pass's parameters (`cumuli.light_grid`
takes them, `cumuli.RenderSettings.light_params` makes the renderer's, and a grid's
:class:`LightRecord` keeps the ones it was made with). A :class:`LightGrid` is a read-only
``[z, y, x]`` float32 array that knows its world box, the sun it was made for and its record;
`LightGrid.save` / :func:`load_light_grid` keep all of it in an ``.npz`` file.
"""

from __future__ import annotations

import hashlib
import json
import os
from collections.abc import Sequence
from dataclasses import asdict, dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np

from cumuli import _core
from cumuli._util import validate as check
from cumuli._util.atomic import atomic_target
from cumuli.io.jsonable import loads as json_loads
from cumuli.io.npz import check_path, check_readable, read_npz
from cumuli.model.cloud import Cloud
from cumuli.noise import PAPER_VERSION, Noise, _fbm_params

#: Largest grid edge along any axis.
MAX_RESOLUTION: int = int(_core.LIGHT_MAX_RESOLUTION)
#: A ray may need at most this many steps (light-box diagonal / step); smaller steps are refused.
MAX_STEPS_PER_RAY: int = int(_core.LIGHT_MAX_STEPS_PER_RAY)
#: Default extinction A of eq. (3), per world unit at density 1. Inside a pseudo-spheroid the fBm
#: densities that pass eq. (2)'s gating are ≈ 0.3–0.6, so A = 0.3 gives a mean free path of about
#: 5–10 units: the default cumulus (`gaussian_cumulus`, ≈ 26 units wide, 17 tall) is then 1–3
#: optical depths thick along a sun ray, and its grid spans bright sunlit tops (L ≈ 1) to dim
#: cores (L ≈ 0.1) instead of saturating black (A = 1 leaves most of the interior below 0.01).
DEFAULT_EXTINCTION: float = 0.3
#: Default γ of eq. (6) in steradians (the paper's ≈ 1e-4); the renderer's grids use it too.
DEFAULT_SOLID_ANGLE: float = 1e-4
METHODS = ("ndt", "naive", "shared")


def _resolution(value: Any) -> tuple[int, int, int]:
    if isinstance(value, (int, np.integer)) and not isinstance(value, bool):
        n = check.integer(value, "resolution", 2, MAX_RESOLUTION)
        return (n, n, n)
    if isinstance(value, Sequence) and not isinstance(value, str) and len(value) == 3:
        x, y, z = (check.integer(v, "resolution", 2, MAX_RESOLUTION) for v in value)
        return (x, y, z)
    raise TypeError(f"resolution must be an int or three ints (x, y, z), got {value!r}")


def _f32(value: float) -> float:
    # The core takes float32: record what it was given, so that 0.1 and np.float32(0.1) agree.
    return float(np.float32(value))


def primitives_digest(cloud: Cloud) -> str:
    """A short hash of the cloud's primitive arrays and, for a cloud the wind has moved, of its
    offset (a grid belongs to these primitives, there)."""
    h = hashlib.blake2b(digest_size=16)
    for a in (cloud.centres, cloud.radii, cloud.rotations):
        h.update(np.ascontiguousarray(a, dtype=np.float32).tobytes())
    if any(cloud.offset):
        h.update(np.asarray(cloud.offset, np.float64).tobytes())
    return h.hexdigest()


@dataclass(frozen=True)
class LightParams:
    """Everything an NDT light grid depends on besides the cloud, the noise and the sun.

    The one home of these parameters: :func:`light_grid` takes them (or the same keywords),
    :meth:`cumuli.RenderSettings.light_params` makes the renderer's, and a grid's
    :class:`LightRecord` keeps the ones it was made with. Values are validated and rounded to
    float32 as the core sees them, so equal parameters compare equal.

    ``resolution`` is one int (a cube) or ``(x, y, z)``; ``method`` ``"ndt"`` or ``"naive"``;
    ``step`` Δ; ``extinction`` A of eq. (3); ``solid_angle`` γ of eq. (6); ``octaves, gain,
    lacunarity, frequency`` the fBm of eq. (1); ``density_override`` a constant density in place of
    fBm (a test hook); ``kappa`` overrides the cloud's κ (spheroids) when set.
    """

    resolution: int | tuple[int, int, int] = 20
    method: str = "ndt"
    step: float = 0.1
    extinction: float = DEFAULT_EXTINCTION
    solid_angle: float = DEFAULT_SOLID_ANGLE
    octaves: int = 5
    gain: float = 0.5
    lacunarity: float = 2.0
    frequency: float = 1.0
    density_override: float | None = None
    kappa: float | None = None

    def __post_init__(self) -> None:
        s = object.__setattr__
        s(self, "resolution", _resolution(self.resolution))
        if not isinstance(self.method, str) or self.method not in METHODS:
            raise ValueError(f"method must be one of {METHODS}, got {self.method!r}")
        s(self, "step", _f32(check.real(self.step, "step", 0.0, lo_open=True)))
        s(self, "extinction", _f32(check.real(self.extinction, "extinction", 0.0)))
        s(self, "solid_angle", _f32(check.real(self.solid_angle, "solid_angle", 0.0, 4 * np.pi)))
        octaves, gain, lacunarity, frequency = _fbm_params(
            self.octaves, self.gain, self.lacunarity, self.frequency
        )
        s(self, "octaves", int(octaves))
        s(self, "gain", _f32(gain))
        s(self, "lacunarity", _f32(lacunarity))
        s(self, "frequency", _f32(frequency))
        if self.density_override is not None:
            s(
                self,
                "density_override",
                _f32(check.real(self.density_override, "density_override", 0.0)),
            )
        if self.kappa is not None:
            s(self, "kappa", _f32(check.real(self.kappa, "kappa", 0.0, 1.0)))

    def replace(self, **changes: Any) -> LightParams:
        """A copy with some fields changed (validated again)."""
        return replace(self, **changes)


@dataclass(frozen=True)
class LightRecord:
    """What a light grid was made from: its :class:`LightParams`, the noise lattice (seed, size),
    the density model with its parameter (κ for spheroids, φ for metaballs) and a digest of the
    primitives; ``shaded``: whether the grid also holds the shadows of the scene's particle clouds
    and billboards (the light step's `onto_media`), so that a copy of one (pickled, saved) given
    back is not shaded twice. Two grids with equal records and suns are equal; the renderer
    recomputes a grid whose record differs from the one its settings give."""

    params: LightParams
    noise: tuple[int, ...] | None  # Noise.identity: (seed, size, version)
    model: str
    kappa: float | None
    phi: float | None
    primitives: str
    shaded: bool = False

    @classmethod
    def of(cls, cloud: Cloud, noise: Noise | None, params: LightParams) -> LightRecord:
        """The record of the grid `light_grid` makes for ``cloud`` with ``noise`` and ``params``."""
        spheroid = cloud.model == "spheroid"
        kappa = params.kappa if params.kappa is not None else _f32(cloud.kappa)
        return cls(
            # The κ the density sees is the record's own field (None for metaballs, where κ
            # plays no part), so an override only matters through it.
            params=params.replace(kappa=None),
            noise=None if noise is None else noise.identity,
            model=cloud.model,
            kappa=kappa if spheroid else None,
            phi=None if spheroid else _f32(cloud.phi),
            primitives=primitives_digest(cloud),
        )


class LightGrid(np.ndarray):
    """A light grid ``L(v)``: a read-only ``(Rz, Ry, Rx)`` float32 array indexed ``[z, y, x]``
    that also knows its world ``box`` ``(lo, hi)`` (voxel ``(i, j, k)``'s centre is
    ``lo + ((i, j, k) + ½)·(hi − lo)/R``), the ``sun`` direction it was made for and its
    ``record`` (:class:`LightRecord`).

    `light_grid` makes them; ``LightGrid(values, box)`` wraps a grid made by hand (no sun, no
    record: the renderer uses it as it is, for any sun). Arithmetic on a grid gives plain arrays.
    """

    box: tuple[tuple[float, float, float], tuple[float, float, float]]
    sun: tuple[float, float, float] | None
    record: LightRecord | None

    def __new__(
        cls,
        values: Any,
        box: Any,
        sun: Any = None,
        record: LightRecord | None = None,
    ) -> LightGrid:
        arr = np.asarray(values)
        if arr.dtype.kind not in "fiu":
            raise TypeError(f"light grid values must be real numbers, got dtype {arr.dtype}")
        if arr.ndim != 3 or min(arr.shape) < 1:
            raise ValueError(f"light grid values must be a (D, H, W) array, got shape {arr.shape}")
        arr = np.array(arr, dtype=np.float32, order="C")  # a private copy
        if not np.isfinite(arr).all():
            raise ValueError("light grid values contain NaN or infinite values")
        if arr.size and float(np.abs(arr).max()) > check.MAX_RADIANCE:
            raise ValueError(
                f"light grid values must be within ±{check.MAX_RADIANCE:g} (MAX_RADIANCE: times "
                "the sun's radiance they would overflow float32)"
            )
        bad_box = f"light grid box must be (lo, hi), two finite 3-vectors with hi > lo, got {box!r}"
        try:
            lo, hi = (check.vec3(v, "box", bound=check.MAX_COORD) for v in box)
        except (TypeError, ValueError):
            raise ValueError(bad_box) from None
        if len(box) != 2 or not all(h > low for low, h in zip(lo, hi, strict=True)):
            raise ValueError(bad_box)
        if record is not None and not isinstance(record, LightRecord):
            raise TypeError(f"record must be a LightRecord or None, got {type(record).__name__}")
        grid = arr.view(cls)
        grid.box = (lo, hi)
        grid.sun = None if sun is None else check.direction(sun, "sun")
        grid.record = record
        grid.setflags(write=False)
        return grid

    def __array_finalize__(self, obj: Any) -> None:
        self.box = getattr(obj, "box", None)  # type: ignore[assignment]
        self.sun = getattr(obj, "sun", None)
        self.record = getattr(obj, "record", None)

    def __array_wrap__(self, out: np.ndarray, context: Any = None, return_scalar: bool = False):
        # Results of arithmetic are plain arrays: a sum of grids has no box or record.
        out = np.asarray(out)
        return out[()] if return_scalar else out

    @property
    def values(self) -> np.ndarray:
        """The grid as a plain read-only float32 ndarray."""
        return self.view(np.ndarray)

    def __reduce__(self) -> Any:
        return (_rebuild_grid, (self.values.copy(), self.box, self.sun, self.record))

    def save(self, path: str | os.PathLike[str]) -> Path:
        """Write the grid, its box, sun and record to an ``.npz`` file, atomically."""
        path = Path(os.fspath(path))
        if path.suffix.lower() != ".npz":
            raise ValueError(f"path must end in .npz, got {path.name!r}")
        if not path.parent.is_dir():
            raise FileNotFoundError(f"folder of path does not exist: {str(path.parent)!r}")
        record = None if self.record is None else asdict(self.record)
        if record is not None and not record["shaded"]:
            del record["shaded"]  # the files of grids as they were before the mark, readable alike
        meta = {
            "format": GRID_FORMAT,
            "version": 1,
            "box": [list(self.box[0]), list(self.box[1])],
            "sun": None if self.sun is None else list(self.sun),
            "record": record,
        }
        text = json.dumps(meta, allow_nan=False)
        with atomic_target(path) as tmp, open(tmp, "wb") as fh:
            np.savez_compressed(
                fh, values=self.values, meta=np.frombuffer(text.encode("utf-8"), np.uint8)
            )
        return path


def _rebuild_grid(values: Any, box: Any, sun: Any, record: Any) -> LightGrid:
    return LightGrid(values, box, sun, record)


#: Format tag of light-grid files.
GRID_FORMAT = "cumuli.light_grid"
#: Largest grid a file may hold (voxels).
MAX_FILE_VOXELS = MAX_RESOLUTION**3


def load_light_grid(path: str | os.PathLike[str]) -> LightGrid:
    """Read a grid written by :meth:`LightGrid.save`; ``FileNotFoundError`` for a missing file,
    ``ValueError`` naming the file for a foreign, truncated or inconsistent one."""
    path = check_path(path, (".npz",))
    check_readable(path, "light-grid")
    arrays = read_npz(path, {"meta": 1 << 20, "values": MAX_FILE_VOXELS}, ("meta", "values"))
    try:
        meta = json_loads(arrays["meta"].tobytes().decode("utf-8"))
        if not isinstance(meta, dict) or meta.get("format") != GRID_FORMAT:
            raise ValueError("not a cumuli light-grid file (format tag missing)")
        rec = meta.get("record")
        record = None
        if rec is not None:
            params = LightParams(**rec.pop("params"))
            noise = rec.pop("noise")
            if noise is not None and len(noise) == 2:  # written before noise versions: the table
                noise = [*noise, PAPER_VERSION]
            record = LightRecord(
                params=params, noise=None if noise is None else tuple(noise), **rec
            )
        return LightGrid(arrays["values"], meta["box"], meta.get("sun"), record)
    except (KeyError, TypeError, ValueError, UnicodeDecodeError) as exc:
        raise ValueError(
            f"{path.name}: not a readable light-grid file ({type(exc).__name__}: {exc})"
        ) from None
