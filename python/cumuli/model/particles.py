"""Particle clouds of Harris 2002 (§2): data, generators, files.

A :class:`ParticleCloud` is ``N`` particles — centres ``(N, 3)``, splat radii ``r_k`` (the
screen-aligned quad has side ``2·r_k``), optical depths ``τ_k`` (default 8.0, [H] §2.3) and
albedos ``a_k`` (default 0.9) — plus provenance (``params``, ``stats``). As a density each
particle is the Gaussian blob ``σ(x) = β_k·exp(−|x − p_k|²/(2 s_k²))``, ``s_k = r_k/3``,
``β_k = τ_k/(s_k·√(2π))`` (:meth:`ParticleCloud.to_volume`).

Clouds are values: :meth:`~ParticleCloud.translated`, :meth:`~ParticleCloud.scaled` and
:meth:`~ParticleCloud.merged` return new clouds and append what they did to
``params["transforms"]``. The particle light (:func:`cumuli.light.particles.particle_light`) is a
separate value, never stored here. Generators run in the C++ core (``model/particles.hpp``),
seeded, bit-identical whatever the thread count.
"""

from __future__ import annotations

import json
import os
import struct
import zipfile
import zlib
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from cumuli import _core
from cumuli._util import validate as check
from cumuli._util.atomic import atomic_target
from cumuli.io.jsonable import array_from_json, array_to_json
from cumuli.io.jsonable import loads as json_loads
from cumuli.io.npz import json_default
from cumuli.model.cloud import Cloud
from cumuli.noise import Noise, _fbm_params, check_fbm_reach

#: Most particles one cloud holds (spec §12.5).
MAX_PARTICLES: int = int(_core.PARTICLES_MAX)
#: Largest particle optical depth τ_k.
MAX_TAU = 100.0
#: Tag and version written into particle files.
FILE_FORMAT = "cumuli.particles"
FILE_VERSION = 1
#: Largest particle file `load_particles` reads.
MAX_FILE_BYTES = 1 << 31
_ARRAYS = ("centres", "radii", "tau", "albedo")
_NPZ_LIMITS = {"centres": 3 * MAX_PARTICLES, "meta": 1 << 28} | {
    k: MAX_PARTICLES for k in ("radii", "tau", "albedo")
}


def _per_particle(value: Any, n: int, name: str, lo: float, hi: float, lo_open: bool) -> np.ndarray:
    """A scalar or ``(n,)`` array of finite values in the range, as read-only float32."""
    if np.ndim(value) == 0:
        v = check.real(value, name, lo, hi, lo_open=lo_open)
        arr = np.full(n, v, dtype=np.float32)
    else:
        raw = np.asarray(value)
        if raw.dtype.kind not in "fiu":
            raise TypeError(f"{name} must be a number or a real numeric array, got {raw.dtype}")
        if raw.shape != (n,):
            raise ValueError(f"{name} must be a number or have shape ({n},), got {raw.shape}")
        arr = np.ascontiguousarray(raw, dtype=np.float32)
        if not np.isfinite(arr).all():
            raise ValueError(f"{name} contains NaN or infinite values")
        bad = (arr <= lo) if lo_open else (arr < lo)
        if bad.any() or (arr > hi).any():
            lo_s = f"({lo}" if lo_open else f"[{lo}"
            raise ValueError(f"{name} must lie in {lo_s}, {hi}]")
        arr = arr.copy()
    arr.flags.writeable = False
    return arr


def _json_ready(obj: Any, name: str) -> Any:
    """``obj`` as plain JSON values (numpy scalars/arrays and tuples converted)."""
    try:
        return json.loads(json.dumps(obj, default=json_default, allow_nan=False))
    except (TypeError, ValueError) as exc:
        raise TypeError(f"{name} must be JSON-serialisable: {exc}") from None


class ParticleCloud:
    """A Harris 2002 particle cloud (spec §2.1). Arrays are read-only float32.

    Parameters
    ----------
    centres:
        ``(N, 3)`` particle centres, ``1 ≤ N ≤ 2²²``.
    radii:
        ``(N,)`` splat radii (> 0), or one number for all.
    tau:
        Optical depth of each particle, in (0, 100]; one number or ``(N,)``.
    albedo:
        Albedo of each particle, in [0, 1]; one number or ``(N,)``.
    params, stats:
        Provenance (generator, arguments, seed, transforms) and generator counts; JSON values.
    """

    #: Tag of this cloud kind in scene files (``Scene.clouds`` mixes kinds).
    kind = "particles"

    def __init__(
        self,
        centres: Any,
        radii: Any,
        tau: Any = 8.0,
        albedo: Any = 0.9,
        *,
        params: Mapping[str, Any] | None = None,
        stats: Mapping[str, Any] | None = None,
    ) -> None:
        pts = check.points3(centres, "centres", allow_empty=False, bound=check.MAX_COORD)
        n = pts.shape[0]
        if n > MAX_PARTICLES:
            raise ValueError(f"a particle cloud holds at most {MAX_PARTICLES} particles, got {n}")
        pts = pts.copy()
        pts.flags.writeable = False
        self._centres = pts
        self._radii = _per_particle(radii, n, "radii", 0.0, check.MAX_COORD, True)
        self._tau = _per_particle(tau, n, "tau", 0.0, MAX_TAU, True)
        self._albedo = _per_particle(albedo, n, "albedo", 0.0, 1.0, False)
        for name, value in (("params", params), ("stats", stats)):
            if value is not None and not isinstance(value, Mapping):
                raise TypeError(f"{name} must be a mapping, got {type(value).__name__}")
        self.params: dict[str, Any] = dict(params or {})
        self.stats: dict[str, Any] = dict(stats or {})
        self._sphere_cache: Any = None

    # --- arrays and geometry ------------------------------------------------------------------
    @property
    def centres(self) -> np.ndarray:
        return self._centres

    @property
    def radii(self) -> np.ndarray:
        return self._radii

    @property
    def tau(self) -> np.ndarray:
        return self._tau

    @property
    def albedo(self) -> np.ndarray:
        return self._albedo

    @property
    def n(self) -> int:
        """Number of particles."""
        return int(self._centres.shape[0])

    def __len__(self) -> int:
        return self.n

    def core_args(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """``(centres, radii, tau, albedo)`` as the C++ core takes them."""
        return self._centres, self._radii, self._tau, self._albedo

    def _sphere_data(self) -> tuple[Any, Any, Any, float]:
        # Arrays are read-only: computed once (renderers ask for it every frame).
        if self._sphere_cache is None:
            self._sphere_cache = _core.particle_sphere(*self.core_args())
        return self._sphere_cache

    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """``(lo, hi)``: the AABB of centres ± radii, float32 as the core computes it."""
        lo, hi, _, _ = self._sphere_data()
        return np.array(lo, dtype=np.float32), np.array(hi, dtype=np.float32)

    def layer_box(self) -> tuple[np.ndarray, np.ndarray]:
        """The box every splat of the cloud lies in: :meth:`bounds` (the compositor's order)."""
        return self.bounds()

    @property
    def sphere(self) -> tuple[np.ndarray, float]:
        """Bounding sphere ``(c, R)``: ``c`` the AABB centre, ``R = max_k(|p_k − c| + r_k)``."""
        _, _, centre, radius = self._sphere_data()
        return np.array(centre, dtype=np.float32), float(radius)

    # --- values derived from this one ---------------------------------------------------------
    def _derived(self, transform: dict[str, Any], centres: np.ndarray, radii: np.ndarray) -> Any:
        params = dict(self.params)
        params["transforms"] = [*self.params.get("transforms", []), transform]
        return ParticleCloud(
            centres, radii, self._tau, self._albedo, params=params, stats=dict(self.stats)
        )

    def translated(self, offset: Sequence[float] | np.ndarray) -> ParticleCloud:
        """The cloud moved by ``offset`` (wind). The light of a cloud only depends on relative
        positions, so a translated cloud can keep using its light."""
        off = check.vec3(offset, "offset", bound=check.MAX_COORD)
        moved = self._centres + np.asarray(off, dtype=np.float32)
        return self._derived({"translate": list(off)}, moved, self._radii)

    def scaled(self, factor: float, about: Sequence[float] | None = None) -> ParticleCloud:
        """Centres and radii scaled by ``factor`` about ``about`` (default: the sphere centre).

        τ is each particle's optical depth through its centre, a dimensionless property, and is
        kept (the blob's extinction coefficient β scales by 1/factor).
        """
        f = check.real(factor, "factor", 0.0, 1e6, lo_open=True)
        centre = self.sphere[0] if about is None else np.asarray(check.vec3(about, "about"))
        c = np.asarray(centre, dtype=np.float32)
        scaled = c + (self._centres - c) * np.float32(f)
        return self._derived(
            {"scale": f, "about": [float(v) for v in c]}, scaled, self._radii * np.float32(f)
        )

    def merged(self, *others: ParticleCloud) -> ParticleCloud:
        """One cloud holding this cloud's particles followed by the others'."""
        parts = [self, *others]
        for i, p in enumerate(parts):
            if not isinstance(p, ParticleCloud):
                raise TypeError(
                    f"merged() takes ParticleClouds, argument {i} is {type(p).__name__}"
                )
        n = sum(p.n for p in parts)
        if n > MAX_PARTICLES:
            raise ValueError(f"merged cloud would hold {n} particles, more than {MAX_PARTICLES}")
        return ParticleCloud(
            np.concatenate([p.centres for p in parts]),
            np.concatenate([p.radii for p in parts]),
            np.concatenate([p.tau for p in parts]),
            np.concatenate([p.albedo for p in parts]),
            params={"generator": "merge", "parts": [p.params for p in parts]},
            stats={"n": n, "parts": [p.n for p in parts]},
        )

    # --- volumes -----------------------------------------------------------------------------
    def to_volume(
        self,
        resolution: int | Sequence[int] = 64,
        box: tuple[Sequence[float], Sequence[float]] | None = None,
        threads: int = 0,
    ) -> tuple[np.ndarray, tuple[tuple[float, ...], tuple[float, ...]]]:
        """The particles' Gaussian-blob extinction on a grid: ``(density [z, y, x], (lo, hi))``.

        ``σ(x) = Σ_k β_k exp(−|x − p_k|²/(2 s_k²))`` at voxel centres, ``s_k = r_k/3``,
        ``β_k = τ_k/(s_k√(2π))`` (spec §2.2), each blob summed within 4 s_k of its centre.
        ``box`` defaults to :meth:`bounds` grown by ``r/3`` of the largest particle.
        ``resolution`` is one int or ``(nx, ny, nz)``.
        """
        res = check.shape3(resolution, "resolution", 2048)
        if box is None:
            lo, hi = self.bounds()
            pad = float(self._radii.max()) / 3.0
            box = (tuple(float(v) - pad for v in lo), tuple(float(v) + pad for v in hi))
        if not isinstance(box, Sequence) or len(box) != 2:
            raise TypeError("box must be (lo, hi)")
        lo3, hi3 = check.vec3(box[0], "box[0]"), check.vec3(box[1], "box[1]")
        if not all(h > low for low, h in zip(lo3, hi3, strict=True)):
            raise ValueError(f"box must have hi > lo on every axis, got {box}")
        vol = _core.particles_to_volume(*self.core_args(), res, lo3, hi3, check.threads(threads))
        return vol, (lo3, hi3)

    @classmethod
    def from_volume(
        cls,
        density: Any,
        box: tuple[Sequence[float], Sequence[float]],
        n: int = 1000,
        seed: int = 0,
        *,
        radius: float | None = None,
        tau: float = 8.0,
        albedo: float = 0.9,
        threads: int = 0,
    ) -> ParticleCloud:
        """Importance-sample a ``(D, H, W)`` density volume ``[z, y, x]`` over ``box``.

        A voxel is drawn with probability ∝ its density and the centre placed uniformly in it;
        ``τ_k = tau·ρ(voxel)/mean(ρ of the drawn voxels)`` (τ ∝ local density, floored at 1e−3,
        at most 100); radius ``(box volume/n)^{1/3}`` (the mean spacing) unless given.
        """
        raw = np.asarray(density)
        if raw.dtype.kind not in "fiu":
            raise TypeError(f"density must be a real numeric array, got dtype {raw.dtype}")
        if raw.ndim != 3 or raw.size == 0:
            raise ValueError(f"density must be a non-empty (D, H, W) volume, got {raw.shape}")
        if raw.size > 1 << 28:
            raise ValueError(f"density has {raw.size} voxels, more than 2^28")
        vol = np.ascontiguousarray(raw, dtype=np.float32)
        if not isinstance(box, Sequence) or len(box) != 2:
            raise TypeError("box must be (lo, hi)")
        lo, hi = check.vec3(box[0], "box[0]"), check.vec3(box[1], "box[1]")
        n = check.integer(n, "n", 1, MAX_PARTICLES)
        seed = check.integer(seed, "seed", 0, 2**64 - 1)
        r = 0.0 if radius is None else check.real(radius, "radius", 0.0, lo_open=True)
        tau = check.real(tau, "tau", 0.0, MAX_TAU, lo_open=True)
        albedo = check.real(albedo, "albedo", 0.0, 1.0)
        c, rad, t, a = _core.particles_from_volume(
            vol, lo, hi, n, r, tau, albedo, 1e-3, seed, check.threads(threads)
        )
        params = {
            "generator": "from_volume",
            "n": n,
            "seed": seed,
            "radius": radius,
            "tau": tau,
            "albedo": albedo,
            "box": [list(lo), list(hi)],
            "volume_shape": list(vol.shape),
        }
        return cls(c, rad, t, a, params=params, stats={"n": n, "radius": float(rad[0])})

    # --- files and scene documents ------------------------------------------------------------
    def _meta(self) -> dict[str, Any]:
        return {
            "format": FILE_FORMAT,
            "version": FILE_VERSION,
            "kind": self.kind,
            "params": _json_ready(self.params, "params"),
            "stats": _json_ready(self.stats, "stats"),
        }

    def to_dict(self) -> dict[str, Any]:
        """A JSON-able document for scene files and ``.json`` saves: ``"kind": "particles"``,
        the arrays as exact base64 float32 (:func:`cumuli.io.jsonable.array_to_json`)."""
        doc = self._meta()
        for key in _ARRAYS:
            doc[key] = array_to_json(getattr(self, key))
        return doc

    @classmethod
    def from_dict(cls, doc: Mapping[str, Any], where: str = "particles") -> ParticleCloud:
        """The cloud of a :meth:`to_dict` document (arrays as base64 objects or nested lists);
        ValueError naming ``where`` and what is wrong."""
        if not isinstance(doc, Mapping):
            raise TypeError(
                f"a particle cloud document must be a mapping, got {type(doc).__name__}"
            )
        if doc.get("kind", cls.kind) != cls.kind:
            raise ValueError(f"document kind must be {cls.kind!r}, got {doc.get('kind')!r}")
        unknown = sorted(set(doc) - {*_ARRAYS, "format", "version", "kind", "params", "stats"})
        if unknown:
            raise ValueError(f"{where} has unknown field(s): {', '.join(unknown)}")
        missing = [k for k in _ARRAYS if k not in doc]
        if missing:
            raise ValueError(f"particle cloud document misses {missing}")
        arrays = {}
        for key in _ARRAYS:
            value = doc[key]  # an ndarray from .npz files, else JSON
            arrays[key] = (
                value if isinstance(value, np.ndarray) else array_from_json(value, f"{where}.{key}")
            )
        params, stats = doc.get("params") or {}, doc.get("stats") or {}
        try:
            return cls(**arrays, params=params, stats=stats)
        except (TypeError, ValueError) as exc:
            raise type(exc)(f"{where}: {exc}") from None

    def save(self, path: str | os.PathLike[str]) -> Path:
        """Write the cloud to ``path`` (``.npz`` or ``.json`` by extension), atomically.

        Arrays, ``params`` and ``stats`` are kept; a failed save leaves no partial file.
        """
        path = Path(os.fspath(path))
        suffix = path.suffix.lower()
        if suffix not in (".npz", ".json"):
            raise ValueError(f"path must end in .npz or .json, got {path.name!r}")
        meta = self._meta()
        if not path.parent.is_dir():
            raise FileNotFoundError(f"folder of path does not exist: {str(path.parent)!r}")
        with atomic_target(path) as tmp, open(tmp, "wb") as fh:
            if suffix == ".npz":
                text = json.dumps(meta, allow_nan=False).encode("utf-8")
                arrays = {k: getattr(self, k) for k in _ARRAYS}
                np.savez_compressed(fh, meta=np.frombuffer(text, dtype=np.uint8), **arrays)
            else:
                fh.write(json.dumps(self.to_dict(), allow_nan=False).encode("utf-8"))
        return path

    def __repr__(self) -> str:
        c, r = self.sphere
        gen = self.params.get("generator", "arrays")
        return (
            f"ParticleCloud(n={self.n}, sphere=({c[0]:.3g}, {c[1]:.3g}, {c[2]:.3g}) r={r:.3g}, "
            f"tau mean={float(self._tau.mean()):.3g}, generator={gen!r})"
        )


def load_particles(path: str | os.PathLike[str]) -> ParticleCloud:
    """Read a cloud written by :meth:`ParticleCloud.save` (``.npz`` or ``.json``).

    ``FileNotFoundError`` for a missing file, ``ValueError`` (naming the file) for an empty,
    truncated, foreign or inconsistent one.
    """
    path = Path(os.fspath(path))
    suffix = path.suffix.lower()
    if suffix not in (".npz", ".json"):
        raise ValueError(f"path must end in .npz or .json, got {path.name!r}")
    if not path.exists():
        raise FileNotFoundError(f"no such particle file: {str(path)!r}")
    if not path.is_file():
        raise OSError(f"not a file: {str(path)!r}")
    size = path.stat().st_size
    if size == 0:
        raise ValueError(f"{path.name}: empty file")
    if size > MAX_FILE_BYTES:
        raise ValueError(f"{path.name}: {size} bytes, more than the limit {MAX_FILE_BYTES}")
    try:
        if suffix == ".npz":
            doc = _read_npz(path)
        else:
            doc = json_loads(path.read_text(encoding="utf-8"))
    except (
        ValueError,  # incl. JSON and UTF-8 errors, numpy's bad .npy magic, Python's int limit
        zipfile.BadZipFile,
        EOFError,
        RecursionError,
        OSError,
        NotImplementedError,  # zipfile: an unknown compression method
        RuntimeError,  # zipfile: an encrypted member
        zlib.error,
        struct.error,
    ) as exc:
        why = f"{type(exc).__name__}: {exc}"
        raise ValueError(f"{path.name}: not a readable cumuli particle file ({why})") from None
    if not isinstance(doc, dict) or doc.get("format") != FILE_FORMAT:
        raise ValueError(f"{path.name}: not a cumuli particle file (format tag missing)")
    if doc.get("version") != FILE_VERSION:
        raise ValueError(f"{path.name}: unsupported particle file version {doc.get('version')!r}")
    try:
        return ParticleCloud.from_dict(doc)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{path.name}: invalid particle data: {exc}") from None


def _read_npz(path: Path) -> dict[str, Any]:
    arrays: dict[str, np.ndarray] = {}
    with zipfile.ZipFile(path) as zf:
        names = set(zf.namelist())
        for key in ("meta", *_ARRAYS):
            if key + ".npy" not in names:
                raise ValueError(f"missing array {key!r}")
            with zf.open(key + ".npy") as fh:
                # The declared shape is checked before numpy allocates it.
                version = np.lib.format.read_magic(fh)
                if version == (1, 0):
                    shape, fortran, dtype = np.lib.format.read_array_header_1_0(fh)
                else:
                    shape, fortran, dtype = np.lib.format.read_array_header_2_0(fh)
                count = int(np.prod(shape, dtype=np.int64)) if shape else 1
                if dtype.hasobject or count > _NPZ_LIMITS[key]:
                    raise ValueError(f"array {key!r} has unacceptable shape/dtype")
                data = fh.read(count * dtype.itemsize)
                if len(data) != count * dtype.itemsize:
                    raise ValueError(f"array {key!r} is truncated")
                order = "F" if fortran else "C"
                arrays[key] = np.frombuffer(data, dtype=dtype).reshape(shape, order=order)
    doc = json_loads(arrays.pop("meta").tobytes().decode("utf-8"))
    if not isinstance(doc, dict):
        raise ValueError("metadata is not an object")
    doc.update(arrays)
    return doc


# --- generators ------------------------------------------------------------------------------
def particle_fill(
    cloud: Cloud,
    n: int = 1000,
    noise: Noise | None = None,
    radius: Sequence[float] | None = None,
    tau: float = 8.0,
    albedo: float = 0.9,
    seed: int = 0,
    *,
    octaves: int = 5,
    gain: float = 0.5,
    lacunarity: float = 2.0,
    frequency: float = 0.3,
    threads: int = 0,
) -> ParticleCloud:
    """Fill the union of ``cloud``'s ellipsoids with ``n`` particles (spec §2.3.1).

    Each centre: a primitive drawn with probability ∝ its volume, a point uniform inside it,
    accepted with probability 1/(number of primitives containing it) — uniform over the union.
    Radius uniform in ``radius = (rmin, rmax)`` (default ``(0.15 r̄, 0.3 r̄)``, r̄ the mean
    primitive radius [decision]). With ``noise``, ``τ_k = tau·fbm(p_k)/mean_k fbm`` (fBm eq. (1)
    of the 2018 paper with ``octaves, gain, lacunarity, frequency``; floored at 1e−3, at most 100),
    else constant ``tau``. Seeded; the same seed gives the same particles on any thread count.
    """
    if not isinstance(cloud, Cloud):
        raise TypeError(f"cloud must be a cumuli.Cloud, got {type(cloud).__name__}")
    if noise is not None and not isinstance(noise, Noise):
        raise TypeError(f"noise must be a cumuli.Noise or None, got {type(noise).__name__}")
    n = check.integer(n, "n", 1, MAX_PARTICLES)
    if radius is None:
        rmin = rmax = 0.0
    else:
        if not isinstance(radius, Sequence) or len(radius) != 2:
            raise TypeError(f"radius must be (rmin, rmax) or None, got {radius!r}")
        rmin = check.real(radius[0], "radius[0]", 0.0, check.MAX_COORD, lo_open=True)
        rmax = check.real(radius[1], "radius[1]", rmin, check.MAX_COORD)
    tau = check.real(tau, "tau", 0.0, MAX_TAU, lo_open=True)
    albedo = check.real(albedo, "albedo", 0.0, 1.0)
    seed = check.integer(seed, "seed", 0, 2**64 - 1)
    # The combinations Noise.fbm refuses (octave weights or scales beyond float32).
    octaves, gain, lacunarity, frequency = _fbm_params(octaves, gain, lacunarity, frequency)
    if noise is not None:
        check_fbm_reach(_reach(cloud), (octaves, gain, lacunarity, frequency), "cloud")
    c, r, t, a = _core.particle_fill(
        _core.CloudShape(*cloud.core_args()),
        n,
        rmin,
        rmax,
        tau,
        albedo,
        None if noise is None else noise._core,
        _core.FbmParams(octaves, gain, lacunarity, frequency),
        1e-3,
        seed,
        check.threads(threads),
    )
    params: dict[str, Any] = {
        "generator": "particle_fill",
        "n": n,
        "radius": None if radius is None else [rmin, rmax],
        "tau": tau,
        "albedo": albedo,
        "seed": seed,
        "noise": None
        if noise is None
        else {"seed": noise.seed, "size": noise.size, "version": noise.version},
        "fbm": {"octaves": octaves, "gain": gain, "lacunarity": lacunarity, "frequency": frequency},
        "cloud": {"primitives": cloud.n, "params": _json_ready(cloud.params, "cloud.params")},
    }
    stats = {
        "n": n,
        "radius_min": float(r.min()),
        "radius_max": float(r.max()),
        "tau_mean": float(t.mean()),
    }
    return ParticleCloud(c, r, t, a, params=params, stats=stats)


def _reach(cloud: Cloud) -> float:
    """The largest coordinate magnitude a particle of ``cloud`` can have (its primitives' box)."""
    if cloud.n == 0:
        return 0.0
    reach = np.abs(cloud.centres).max(axis=1) + np.abs(cloud.radii).max(axis=1)
    return float(reach.max())


def particle_cumulus(
    centre: Sequence[float] = (0.0, 0.0, 0.0),
    n_particles: int = 200,
    seed: int = 0,
    *,
    noise: Noise | None = None,
    radius: Sequence[float] | None = None,
    tau: float = 8.0,
    albedo: float = 0.9,
    threads: int = 0,
    **cumulus: Any,
) -> ParticleCloud:
    """A Gaussian cumulus (``cumuli.gaussian_cumulus(centre, seed=seed, **cumulus)``) filled
    with ``n_particles`` particles by :func:`particle_fill` — the "200 particles per cloud"
    clouds of [H] Fig. 8 by default."""
    from cumuli.model.gaussian import gaussian_cumulus

    shape = gaussian_cumulus(centre=centre, seed=seed, **cumulus)
    pc = particle_fill(shape, n_particles, noise, radius, tau, albedo, seed=seed, threads=threads)
    params = dict(pc.params)
    params["generator"] = "particle_cumulus"
    params["centre"] = list(check.vec3(centre, "centre"))
    params["cumulus"] = _json_ready(cumulus, "cumulus arguments")
    return ParticleCloud(*pc.core_args(), params=params, stats=pc.stats)
