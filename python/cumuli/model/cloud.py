"""`Cloud`: a set of ellipsoid primitives plus the density model that fills them (DESIGN §4).

Primitives are numpy arrays: ``centres (N, 3)``, ``radii (N, 3)`` and ``rotations (N, 3, 3)``
(float32; a rotation's columns are the ellipsoid's axes in world space, spheres have equal radii
and the identity). The density model is ``"spheroid"`` (eq. 2, parameter κ) or ``"metaball"``
(eqs. 19–21, parameter φ and the mean squared radius r̄² of eq. 20). A cloud describes shape only:
its light is computed by the light stage (`cumuli.light_grid`, `cumuli.prepare_light`) and never
stored on it.

Clouds are values: `Cloud.translated`, `Cloud.scaled`, `Cloud.with_model` and `merge` return new
clouds and append what they did to
``params["transforms"]``, so that a saved cloud says how it was made.

The wind moves a cloud whole: a cloud with a ``wind`` (units per second) at ``time`` stands
``offset = drift + wind · time`` from its ``centres`` and carries its fBm (read at
``p − offset``): the same medium wherever it is taken, lit once for every time (`Cloud.at`) and
every copy (`Cloud.drifted`). `Cloud.translated` keeps the world's noise, as the paper's.
`Cloud.save` writes ``.npz`` or ``.json`` atomically; `load_cloud` reads either back.
"""

from __future__ import annotations

import copy
import dataclasses
import json
import math
import os
import struct
import zipfile
import zlib
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, ClassVar

import numpy as np

from cumuli._util import validate as check
from cumuli._util.atomic import atomic_target
from cumuli.io.jsonable import jsonable
from cumuli.io.jsonable import loads as json_loads
from cumuli.io.npz import check_path, check_readable, json_default, read_npz
from cumuli.noise import _fbm_params

DENSITY_MODELS = ("spheroid", "metaball")
#: Most primitives a cloud may hold.
MAX_PRIMITIVES = 1 << 20
#: Largest |RᵀR − I| accepted for a primitive's rotation (float32 rounding is ~1e-7).
ROTATION_TOLERANCE = 1e-3
#: Tag and version written into saved clouds.
FILE_FORMAT = "cumuli.cloud"
FILE_VERSION = 2
#: Versions `load_cloud` reads (version 1 files may carry a light grid, which is ignored).
READABLE_VERSIONS = (1, 2)
#: Largest element count of each array in a saved ``.npz`` (checked before it is inflated).
_NPZ_LIMITS = {
    "centres": 3 * MAX_PRIMITIVES,
    "radii": 3 * MAX_PRIMITIVES,
    "rotations": 9 * MAX_PRIMITIVES,
    "meta": 1 << 28,
}


#: Fields of a cloud's scene-file dict (`Cloud.to_dict`; ``wind``, ``time``, ``drift`` when set).
_DICT_FIELDS = ("kind", "centres", "radii", "rotations", "model", "kappa", "phi", "params", "stats")
#: What a cloud's wind may be: ``(wx, wz)`` (horizontal, as a `CloudDeck`'s) or ``(wx, wy, wz)``.
_NO_WIND = (0.0, 0.0, 0.0)


@dataclass(eq=False)
class Cloud:
    """A cloud: primitives, density model and provenance (``params``, ``stats``).

    The drawable of kind ``"cloud"``: the 2018 paper's ray marcher draws it (see ARCHITECTURE.md).
    ``wind`` (``(wx, wz)`` or ``(wx, wy, wz)``, world units per second), ``time`` (seconds) and
    ``drift`` (world units) move it, noise and all, by ``drift + wind · time`` from its
    ``centres`` (the module's docstring).
    """

    #: Scene-file tag of this kind of drawable.
    kind: ClassVar[str] = "cloud"

    centres: np.ndarray
    radii: np.ndarray
    rotations: np.ndarray | None = None
    model: str = "spheroid"
    kappa: float = 0.5
    phi: float = 0.6
    stats: dict[str, Any] = field(default_factory=dict)
    params: dict[str, Any] = field(default_factory=dict)
    wind: Sequence[float] = _NO_WIND  # kept as (wx, wy, wz)
    time: float = 0.0
    drift: Sequence[float] = _NO_WIND

    def __setattr__(self, name: str, value: Any) -> None:
        if name not in _FIELD_NAMES:
            if name in ("light", "light_box", "light_sun", "light_params"):
                raise AttributeError(
                    f"Cloud.{name} no longer exists: a cloud describes shape only. Light is the "
                    "light stage's: cu.light_grid(...) returns a cu.LightGrid (values, box, sun, "
                    "record); give one to cu.prepare_light(scene, lights=[grid])"
                )
            raise AttributeError(f"Cloud has no field {name!r}")
        object.__setattr__(self, name, value)

    def __post_init__(self) -> None:
        self.centres = check.points3(self.centres, "centres", allow_empty=False)
        n = self.centres.shape[0]
        if n > MAX_PRIMITIVES:
            raise ValueError(f"a cloud holds at most {MAX_PRIMITIVES} primitives, got {n}")
        radii = np.asarray(self.radii)
        if radii.ndim == 1:  # spheres: one radius each
            if radii.shape[0] != n:
                raise ValueError(f"radii must have {n} entries, got {radii.shape[0]}")
            radii = np.repeat(radii.reshape(n, 1), 3, axis=1)
        self.radii = check.points3(radii, "radii")
        if self.radii.shape[0] != n:
            raise ValueError(f"radii must have {n} rows, got {self.radii.shape[0]}")
        if (self.radii <= 0).any():
            raise ValueError("radii must be positive")
        if self.rotations is None:
            self.rotations = np.repeat(np.eye(3, dtype=np.float32)[None], n, axis=0)
        rot = np.asarray(self.rotations)
        if rot.dtype.kind not in "fiu":
            raise TypeError(f"rotations must be numeric, got dtype {rot.dtype}")
        if rot.shape != (n, 3, 3):
            raise ValueError(f"rotations must have shape ({n}, 3, 3), got {rot.shape}")
        self.rotations = np.ascontiguousarray(rot, dtype=np.float32)
        if not np.isfinite(self.rotations).all():
            raise ValueError("rotations contain NaN or infinite values")
        # Columns are the ellipsoid's axes: they must be orthonormal, or the unit-sphere frame
        # q = Rᵀ(p − c)/r and the world bounds (from R's columns) describe different shapes and
        # boxes clip the primitive. Float32 rounding of a true rotation is far inside 1e-3.
        rtr = np.einsum("nji,njk->nik", self.rotations.astype(np.float64), self.rotations)
        err = np.abs(rtr - np.eye(3)).max(axis=(1, 2)) if n else np.zeros(0)
        if (err > ROTATION_TOLERANCE).any():
            i = int(np.argmax(err))
            raise ValueError(
                f"rotations[{i}] is not orthonormal (|RᵀR − I| = {err[i]:.3g}): its columns must "
                "be the ellipsoid's unit axes; put scale in radii"
            )
        self.wind = check.wind3(self.wind, "wind")
        self.time = check.real(self.time, "time", -check.MAX_COORD, check.MAX_COORD)
        self.drift = check.vec3(self.drift, "drift", bound=check.MAX_COORD)
        off = self.offset
        if not all(abs(v) <= check.MAX_COORD for v in off):
            raise ValueError(f"drift + wind · time must stay within ±{check.MAX_COORD:g}: {off}")
        # Every primitive's world bounds (where it is now) must be float32-representable: the
        # core and the shaders compute boxes in float32, and an overflowing one turns into NaN.
        rot64 = self.rotations.astype(np.float64)
        half = np.sqrt(np.einsum("nkj,nj->nk", rot64**2, self.radii.astype(np.float64) ** 2))
        reach = np.abs(self.centres.astype(np.float64) + np.array(off)) + half
        if not (reach < float(np.finfo(np.float32).max) / 4).all():
            raise ValueError("centres ± radii must stay well inside the float32 range (< 8.5e37)")
        if self.model not in DENSITY_MODELS:
            raise ValueError(f"model must be one of {DENSITY_MODELS}, got {self.model!r}")
        self.kappa = check.real(self.kappa, "kappa", 0.0, 1.0)
        self.phi = check.real(self.phi, "phi", 0.0, lo_open=True)

    # --- derived geometry -------------------------------------------------------------------
    @property
    def offset(self) -> tuple[float, float, float]:
        """``drift + wind · time``: how far the cloud and its noise are from ``centres``."""
        (dx, dy, dz), (wx, wy, wz), t = self.drift, self.wind, self.time
        return (dx + wx * t, dy + wy * t, dz + wz * t)

    @property
    def placed_centres(self) -> np.ndarray:
        """The primitives' centres where the cloud is now (``centres`` moved by :attr:`offset`),
        float32 ``(N, 3)``; ``centres`` itself for a cloud the wind has not moved."""
        off = self.offset
        if not any(off):
            return self.centres
        return (self.centres.astype(np.float64) + np.array(off)).astype(np.float32)

    def at(self, time: float) -> Cloud:
        """This cloud at another ``time``, moved by its wind (arrays, params, stats shared)."""
        fields = {name: getattr(self, name) for name in _FIELD_NAMES}
        fields["time"] = check.real(time, "time", -check.MAX_COORD, check.MAX_COORD)
        return Cloud(**fields)

    def still(self) -> Cloud:
        """This cloud at its ``centres``, with the world's noise (its light, moved by
        :attr:`offset`, is this cloud's: the light step computes it once for every place); its
        arrays, params and stats are shared, as :meth:`at`'s."""
        if not self._motion():
            return self
        still = copy.copy(self)  # fields already checked: a light step asks several times
        for name, value in (("wind", _NO_WIND), ("time", 0.0), ("drift", _NO_WIND)):
            object.__setattr__(still, name, value)
        return still

    @property
    def n(self) -> int:
        """Number of primitives."""
        return int(self.centres.shape[0])

    def __len__(self) -> int:
        return self.n

    def bounds(self, scale: float = 1.0) -> tuple[np.ndarray, np.ndarray]:
        """Bounds ``(min, max)`` of the primitives with radii multiplied by ``scale``, float32.

        The same float32 operations as the core's ``Ellipsoid::bounds`` (so the GL marcher,
        packed from these, and the C++ one see the same boxes): radii·scale, half extent along
        world axis k ``sqrt(Σ_j (R_kj·r_j)²)`` summed over j in order, min / max of ``c ∓ half``.
        """
        radii = self.radii * np.float32(scale)
        v = self.rotations * radii[:, None, :]  # v[n, k, j] = R_kj · r_j
        v = v * v
        half = np.sqrt((v[..., 0] + v[..., 1]) + v[..., 2])
        centres = self.placed_centres
        return (centres - half).min(axis=0), (centres + half).max(axis=0)

    @property
    def candidate_scale(self) -> float:
        """Radius factor that makes the primitives bound the density (RENDER_CONTRACT): 1 for
        spheroids, √N for metaballs (``Σ 1/|qᵢ|² ≥ 1`` needs some ``|qᵢ| ≤ √N``)."""
        return math.sqrt(max(self.n, 1)) if self.model == "metaball" else 1.0

    def layer_box(self) -> tuple[np.ndarray, np.ndarray]:
        """The box the marcher draws this cloud in (primitives grown by `candidate_scale`); the
        compositor orders clouds by a ray's entry into it."""
        return self.bounds(self.candidate_scale)

    @property
    def bbox(self) -> tuple[np.ndarray, np.ndarray]:
        """World axis-aligned bounds ``(min, max)`` of the primitives, float32 (3,) each."""
        return self.bounds()

    @property
    def centre(self) -> np.ndarray:
        """Centre of the bounding box (the LOD step measures the camera distance to it)."""
        lo, hi = self.bbox
        return np.float32(0.5) * (lo + hi)

    @property
    def mean_r2(self) -> float:
        """r̄² of eq. (20): the mean squared radius (an ellipsoid counts the mean of its radii²).

        Computed as the core's ``CloudShape::mean_squared_radius`` does: float32 ``r·r`` per
        primitive, ``/ 3`` and summed in order in double, ``/ N``.
        """
        r = self.radii
        rr = (r[:, 0] * r[:, 0] + r[:, 1] * r[:, 1]) + r[:, 2] * r[:, 2]
        return float(np.cumsum(rr.astype(np.float64) / 3.0)[-1] / self.n)  # cumsum: in order

    def core_args(
        self,
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, str, float, float, tuple[float, ...] | None]:
        """The arguments the C++ core takes for a cloud (``_core.CloudShape``'s): its primitives
        where it is now, its density model, and its noise offset (None: the world's noise)."""
        off = self.offset
        return (self.placed_centres, self.radii, self.rotations, self.model, self.kappa, self.phi,
                off if any(off) else None)  # fmt: skip

    def density(
        self,
        points: Any,
        noise: Any = None,
        constant: float | None = None,
        octaves: int = 5,
        gain: float = 0.5,
        lacunarity: float = 2.0,
        frequency: float = 1.0,
        threads: int = 0,
    ) -> tuple[np.ndarray, np.ndarray]:
        """The core's density at ``(N, 3)`` points: ``(rho, gamma)``, float32 ``(N,)`` each.

        ``model="spheroid"``: eq. (2) for the primitive the point is deepest inside (smallest
        normalised distance); ``gamma`` is eq. (2)'s γ. ``model="metaball"``: eqs. (19)–(21),
        ``rho = fbm · r̄² · φ`` where ``Σ 1/|q_i|² ≥ 1`` (``Σ r_i²/|p − c_i|²`` for spheres), else 0;
        ``gamma`` = 1. The noise is a `cumuli.Noise` (fBm with the given parameters) or, for
        analytic checks, a ``constant`` value in place of fBm.
        """
        from cumuli import _core

        pts = check.points3(points, "points")
        if (noise is None) == (constant is None):
            raise ValueError("give exactly one of noise or constant")
        core_noise = None
        const = -1.0
        if noise is not None:
            core_noise = getattr(noise, "_core", None)
            if core_noise is None:
                raise TypeError(f"noise must be a cumuli.Noise, got {type(noise).__name__}")
        else:
            const = check.real(constant, "constant", 0.0)
        fbm = _core.FbmParams(*_fbm_params(octaves, gain, lacunarity, frequency))
        return _core.cloud_density(
            _core.CloudShape(*self.core_args()), pts, core_noise, const, fbm,
            check.threads(threads),
        )  # fmt: skip

    # --- transforms (new clouds) ----------------------------------------------------------
    def _derived(self, transform: dict[str, Any], **changes: Any) -> Cloud:
        params = json.loads(json.dumps(self.params, default=json_default))
        params.setdefault("transforms", []).append(transform)
        fields: dict[str, Any] = {
            "centres": self.centres.copy(),
            "radii": self.radii.copy(),
            "rotations": self.rotations.copy(),
            "model": self.model,
            "kappa": self.kappa,
            "phi": self.phi,
            "stats": dict(self.stats),
            "params": params,
            "wind": self.wind,
            "time": self.time,
            "drift": self.drift,
        }
        fields.update(changes)
        return Cloud(**fields)

    def translated(self, offset: Sequence[float] | np.ndarray) -> Cloud:
        """A copy moved by ``offset`` (world units); its noise stays the world's, as in the
        paper (:meth:`drifted` carries the noise along instead)."""
        off = check.vec3(offset, "offset")
        centres = (self.centres.astype(np.float64) + np.array(off)).astype(np.float32)
        return self._derived({"translate": list(off)}, centres=centres)

    def drifted(self, offset: Sequence[float] | np.ndarray) -> Cloud:
        """A copy moved by ``offset`` (world units) with its noise: the same medium elsewhere,
        whose light is this one's moved (a field of copies is lit once)."""
        off = check.vec3(offset, "offset")
        drift = tuple(float(np.float64(a) + b) for a, b in zip(self.drift, off, strict=True))
        return self._derived({"drift": list(off)}, drift=drift)

    def scaled(self, factor: float, about: Sequence[float] | None = None) -> Cloud:
        """A copy scaled uniformly by ``factor`` > 0 about ``about`` (default: the cloud's centre).

        Centres move away from ``about`` and every radius is multiplied by ``factor``; rotations
        are unchanged.
        """
        f = check.real(factor, "factor", 0.0, lo_open=True)
        pivot = check.vec3(about, "about") if about is not None else tuple(map(float, self.centre))
        p = np.array(pivot) - np.array(self.offset)  # the pivot among the primitives' centres
        centres = ((self.centres.astype(np.float64) - p) * f + p).astype(np.float32)
        radii = (self.radii.astype(np.float64) * f).astype(np.float32)
        if not (np.isfinite(centres).all() and np.isfinite(radii).all() and (radii > 0).all()):
            raise ValueError(f"factor {f} makes the cloud's primitives non-finite or zero")
        return self._derived({"scale": f, "about": list(pivot)}, centres=centres, radii=radii)

    def with_model(self, model: str, kappa: float | None = None, phi: float | None = None) -> Cloud:
        """A copy filled by another density model (``"spheroid"`` or ``"metaball"``).

        The metaball model (eqs. 19–21) works on any primitive set: its iso-surface
        ``Σ 1/|q_i|² ≥ 1`` uses each primitive's unit-sphere frame.
        """
        if model not in DENSITY_MODELS:
            raise ValueError(f"model must be one of {DENSITY_MODELS}, got {model!r}")
        return self._derived(
            {"model": model, "kappa": kappa, "phi": phi},
            model=model,
            kappa=self.kappa if kappa is None else kappa,
            phi=self.phi if phi is None else phi,
        )

    def merged(self, *others: Cloud) -> Cloud:
        """This cloud and ``others`` as one cloud (see `merge`)."""
        return merge([self, *others])

    # --- scene files --------------------------------------------------------------------------
    def to_dict(self) -> dict[str, Any]:
        """The cloud as JSON types for scene files: primitives, density model and parameters
        (and its ``wind``, ``time`` and ``drift`` when they are set)."""
        return self._motion() | {
            "kind": self.kind,
            "centres": self.centres.tolist(),
            "radii": self.radii.tolist(),
            "rotations": self.rotations.tolist(),
            "model": self.model,
            "kappa": self.kappa,
            "phi": self.phi,
            "params": jsonable(self.params),
            "stats": jsonable(self.stats),
        }

    def _motion(self) -> dict[str, Any]:
        """``wind``, ``time`` and ``drift`` as JSON types, those that are set (files of still
        clouds are as they were)."""
        motion = {"wind": list(self.wind), "time": self.time, "drift": list(self.drift)}
        return {k: v for k, v in motion.items() if (any(v) if isinstance(v, list) else v)}

    @classmethod
    def from_dict(cls, data: Any, where: str = "cloud") -> Cloud:
        """Inverse of :meth:`to_dict`; missing or unknown fields raise ValueError naming them."""
        if not isinstance(data, dict):
            raise ValueError(f"{where} must be a JSON object, got {type(data).__name__}")
        missing = [k for k in ("centres", "radii") if k not in data]
        if missing:
            raise ValueError(f"{where} is missing field(s): {', '.join(missing)}")
        known = {*_DICT_FIELDS, "wind", "time", "drift"}
        unknown = sorted(set(data) - known)
        if unknown:
            raise ValueError(f"{where} has unknown field(s): {', '.join(unknown)}")
        return cls(
            centres=np.asarray(data["centres"], dtype=np.float32),
            radii=np.asarray(data["radii"], dtype=np.float32),
            rotations=None
            if data.get("rotations") is None
            else np.asarray(data["rotations"], dtype=np.float32),
            model=data.get("model", "spheroid"),
            kappa=data.get("kappa", 0.5),
            phi=data.get("phi", 0.6),
            params=dict(data.get("params") or {}),
            stats=dict(data.get("stats") or {}),
            wind=data.get("wind", _NO_WIND),
            time=data.get("time", 0.0),
            drift=data.get("drift", _NO_WIND),
        )

    # --- files --------------------------------------------------------------------------------
    def save(self, path: str | os.PathLike[str]) -> Path:
        """Write the cloud to ``path`` (``.npz`` or ``.json``, by extension), atomically.

        Everything needed to use or rebuild it is kept: primitives, density model and parameters,
        ``stats`` and ``params`` (generator, arguments, seed, transforms).
        The file is written to a temporary in the same folder and renamed into place, so a failed
        save leaves no partial file. Returns the path written.
        """
        path = Path(os.fspath(path))
        suffix = path.suffix.lower()
        if suffix not in (".npz", ".json"):
            raise ValueError(f"path must end in .npz or .json, got {path.name!r}")
        meta = self._meta()
        try:
            meta_text = json.dumps(meta, default=json_default, allow_nan=False)
        except (TypeError, ValueError) as exc:
            raise TypeError(f"params/stats must be JSON-serialisable: {exc}") from None
        if not path.parent.is_dir():
            raise FileNotFoundError(f"folder of path does not exist: {str(path.parent)!r}")
        with atomic_target(path) as tmp, open(tmp, "wb") as fh:
            if suffix == ".npz":
                arrays: dict[str, np.ndarray] = {
                    "centres": self.centres,
                    "radii": self.radii,
                    "rotations": self.rotations,
                    "meta": np.frombuffer(meta_text.encode("utf-8"), dtype=np.uint8),
                }
                np.savez_compressed(fh, **arrays)
            else:
                doc = dict(meta)
                doc["centres"] = self.centres.tolist()
                doc["radii"] = self.radii.tolist()
                doc["rotations"] = self.rotations.tolist()
                text = json.dumps(doc, default=json_default, allow_nan=False)
                fh.write(text.encode("utf-8"))
        return path

    def _meta(self) -> dict[str, Any]:
        return {
            "format": FILE_FORMAT,
            "version": FILE_VERSION,
            "model": self.model,
            "kappa": self.kappa,
            "phi": self.phi,
            "stats": self.stats,
            "params": self.params,
        } | self._motion()

    def __repr__(self) -> str:
        lo, hi = self.bbox
        motion = "".join(f", {k}={v}" for k, v in self._motion().items())
        return (
            f"Cloud(n={self.n}, model={self.model!r}, bbox=({lo.round(2).tolist()}, "
            f"{hi.round(2).tolist()}){motion})"
        )


_FIELD_NAMES = frozenset(f.name for f in dataclasses.fields(Cloud))


def merge(clouds: Iterable[Cloud]) -> Cloud:
    """One cloud holding the primitives of all ``clouds`` (in order).

    All clouds must share the density model and its parameters (κ, φ): one cloud has one density
    model. ``params`` records the parts' params; ``stats`` their stats.
    """
    try:
        parts = list(clouds)
    except TypeError:
        raise TypeError(
            f"clouds must be an iterable of Clouds, got {type(clouds).__name__}"
        ) from None
    if not parts:
        raise ValueError("clouds must not be empty")
    for i, c in enumerate(parts):
        if not isinstance(c, Cloud):
            raise TypeError(f"clouds[{i}] must be a Cloud, got {type(c).__name__}")
    first = parts[0]
    for i, c in enumerate(parts[1:], 1):
        if (c.model, c.kappa, c.phi) != (first.model, first.kappa, first.phi):
            raise ValueError(
                f"clouds[{i}] has model={c.model!r}, kappa={c.kappa}, phi={c.phi}; "
                f"clouds[0] has model={first.model!r}, kappa={first.kappa}, phi={first.phi}: "
                "convert with Cloud.with_model first"
            )
        if (c.wind, c.time, c.drift) != (first.wind, first.time, first.drift):
            raise ValueError(
                f"clouds[{i}] has wind={c.wind}, time={c.time}, drift={c.drift}; clouds[0] has "
                f"wind={first.wind}, time={first.time}, drift={first.drift}: one cloud carries "
                "one noise offset"
            )
    total = sum(c.n for c in parts)
    if total > MAX_PRIMITIVES:
        raise ValueError(f"merged cloud would hold {total} primitives, more than {MAX_PRIMITIVES}")
    return Cloud(
        np.concatenate([c.centres for c in parts]),
        np.concatenate([c.radii for c in parts]),
        np.concatenate([c.rotations for c in parts]),
        model=first.model,
        kappa=first.kappa,
        phi=first.phi,
        stats={"parts": [dict(c.stats) for c in parts], "n": total},
        params={
            "generator": "merge",
            "parts": [json.loads(json.dumps(c.params, default=json_default)) for c in parts],
        },
        wind=first.wind,
        time=first.time,
        drift=first.drift,
    )


def load_cloud(path: str | os.PathLike[str]) -> Cloud:
    """Read a cloud written by `Cloud.save` (``.npz`` or ``.json``).

    Raises ``FileNotFoundError`` for a missing file and ``ValueError`` (naming the file) for an
    empty, truncated, foreign or inconsistent one.
    """
    path = check_path(path, (".npz", ".json"))
    check_readable(path, "cloud")
    suffix = path.suffix.lower()
    try:
        if suffix == ".npz":
            meta, arrays = _read_npz(path)
        else:
            meta, arrays = _read_json(path)
    except (
        ValueError,  # incl. JSON and UTF-8 errors, and numpy's bad .npy magic (no file name)
        zipfile.BadZipFile,
        EOFError,
        RecursionError,  # absurdly nested JSON
        NotImplementedError,  # zipfile: an unknown compression method
        RuntimeError,  # zipfile: an encrypted member
        zlib.error,
        struct.error,
    ) as exc:
        if isinstance(exc, ValueError) and str(exc).startswith(f"{path.name}:"):
            raise
        why = f"{type(exc).__name__}: {exc}"
        raise ValueError(f"{path.name}: not a readable cumuli cloud file ({why})") from None
    if not isinstance(meta, dict) or meta.get("format") != FILE_FORMAT:
        raise ValueError(f"{path.name}: not a cumuli cloud file (format tag missing)")
    if meta.get("version") not in READABLE_VERSIONS:
        raise ValueError(f"{path.name}: unsupported cloud file version {meta.get('version')!r}")
    for key in ("model", "kappa", "phi"):
        if key not in meta:
            raise ValueError(f"{path.name}: missing {key!r}")
    try:
        return Cloud(
            arrays["centres"],
            arrays["radii"],
            arrays["rotations"],
            model=meta["model"],
            kappa=meta["kappa"],
            phi=meta["phi"],
            stats=dict(meta.get("stats") or {}),
            params=dict(meta.get("params") or {}),
            wind=meta.get("wind", _NO_WIND),
            time=meta.get("time", 0.0),
            drift=meta.get("drift", _NO_WIND),
        )
    except (ValueError, TypeError, KeyError, IndexError) as exc:
        raise ValueError(f"{path.name}: invalid cloud data: {exc}") from None


def _read_npz(path: Path) -> tuple[Any, dict[str, np.ndarray]]:
    # Each member's declared shape is checked against its limit before numpy allocates it.
    arrays = read_npz(path, _NPZ_LIMITS, ("centres", "radii", "rotations", "meta"))
    meta = json_loads(arrays.pop("meta").tobytes().decode("utf-8"))
    return meta, arrays


def _read_json(path: Path) -> tuple[Any, dict[str, np.ndarray]]:
    doc = json_loads(path.read_text(encoding="utf-8"))
    if not isinstance(doc, dict):
        raise ValueError(f"{path.name}: not a cumuli cloud file (top level is not an object)")
    if doc.get("format") != FILE_FORMAT:
        raise ValueError(f"{path.name}: not a cumuli cloud file (format tag missing)")
    arrays: dict[str, np.ndarray] = {}
    for key in ("centres", "radii", "rotations"):
        if key not in doc:
            raise ValueError(f"{path.name}: missing {key!r}")
        try:
            arrays[key] = np.asarray(doc[key], dtype=np.float32)
        except (TypeError, ValueError) as exc:
            raise ValueError(f"{path.name}: {key} is not a numeric array ({exc})") from None
    return doc, arrays
