"""Cloud decks: stratus, stratocumulus and altostratus layers (the drawable of kind ``"deck"``).

A :class:`CloudDeck` is a slab between two heights, very large in x and z, whose coverage comes
from a 2D weather map, whose vertical density follows a profile per cloud type, and whose edges
are eroded by the fBm of Jiménez de Parga & Gómez Palomo 2018 (eq. 1, :class:`cumuli.Noise`).
The height gradients and the coverage and erosion remaps follow Schneider 2015, "The real-time
volumetric cloudscapes of Horizon Zero Dawn" (SIGGRAPH Advances in Real-Time Rendering). It is
drawn by baking it to a density lattice (:meth:`CloudDeck.to_volume`) that the volume renderer
draws. The density is C++ (``cpp/include/cumuli/model/deck.hpp``).

The model, at a world point ``(x, y, z)`` with ``s(a, b, t)`` the smoothstep
(``t' = clamp((t − a)/(b − a), 0, 1)``, ``s = t'²(3 − 2t')``)::

    h = (y − base)/(top − base)                    ρ = 0 outside 0 ≤ h ≤ 1
    P(h), the type's vertical profile in [0, 1]:
      stratus        P = s(0, 0.1, h) · (1 − s(0.6, 0.95, h))   low, flat, soft base and top
      stratocumulus  P = s(0, 0.25, h) · (1 − s(0.3, 1, h))     densest low-middle, tapering
      altostratus    P = s(0.6, 0.75, h) · (1 − s(0.85, 1, h))  thin, high, smooth
    c = map(x − ox, z − oz)                        the [z, x] weather map, bilinear at texel
                                                   centres over `extent`, clamped at its edges;
                                                   (ox, oz) = wind · time
    f = fbm(x − ox, y, z − oz) / Σᵢ 0.5ⁱ            the 2018 fBm (octaves, gain 0.5, lacunarity 2,
                                                   frequency 1/(2·detail_scale): its first
                                                   octave's lattice texels are detail_scale
                                                   apart), normalised to [0, 1)
    n = clamp(½ + k·(f − ½), 0, 1)                 its contrast raised by k = 3
                                                   (`DETAIL_CONTRAST`: f has a std of ≈ 0.09)
    b = P + c − 1                                  coverage remap, c·remap(P, 1 − c, 1, 0, 1)
    e = detail · (1 − n)                           erosion
    ρ = density · clamp((b − e)/(1 − e), 0, 1)     erosion remap, remap(b, e, 1, 0, 1)

So the layer exists where coverage is high; where it is lower only the profile's core survives
(a stratocumulus' tops sink and its cells round off over the map's lows), the fBm eats its edges,
0 ≤ ρ ≤ density, and ρ = 0 wherever c = 0. The fBm moves with the map: the deck at time t is the
deck at time 0 translated by the wind offset — the whole layer, its slab included (a weather
system the wind carries): its box is ``extent`` moved by ``(ox, oz)``, its baked lattice the time-0
lattice, and its light the time-0 light moved (the light step lights a drifting deck once).
"""

from __future__ import annotations

import copy
import dataclasses
import functools
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any, ClassVar

import numpy as np

from cumuli import _core
from cumuli._util import budget
from cumuli._util import validate as check
from cumuli.io.jsonable import array_from_json, array_to_json
from cumuli.model.volume import MAX_SIGMA_T, VolumeCloud
from cumuli.noise import (
    DEFAULT_VERSION,
    NOISE_VERSIONS,
    PAPER_VERSION,
    Noise,
    _fbm_params,
    check_fbm_reach,
)

#: The cloud types a deck can be.
CLOUD_TYPES = ("stratus", "stratocumulus", "altostratus")
#: Largest edge of a deck's baked lattice, and its most voxels.
MAX_LATTICE_EDGE = 1024
MAX_LATTICE_VOXELS = 1 << 27
#: Bytes per voxel of a deck's baked volume and its light (float32 density, RGBA light).
BYTES_PER_VOXEL = 20
#: Largest edge of a given weather map (and of an fBm-made one: `MAP_SIZE_MAX`).
MAX_MAP_EDGE = 4096
MAP_SIZE_MAX = 1024
#: The fBm of an fBm-made weather map: octaves, gain, lacunarity (frequency 1/(2·map_scale)).
MAP_FBM = (4, 0.5, 2.0)
#: k, the contrast of the detail fBm about ½ (the core's ``DECK_DETAIL_CONTRAST``).
DETAIL_CONTRAST = float(_core.DECK_DETAIL_CONTRAST)
#: Gain and lacunarity of the detail fBm.
DETAIL_GAIN = 0.5
DETAIL_LACUNARITY = 2.0


@functools.lru_cache(maxsize=8)
def _noise(seed: int, version: int) -> Noise:
    """The 64³ lattice of ``seed`` and noise ``version`` (shared by the decks that use it)."""
    return Noise(seed, 64, version)


def _texel_centres(lo: float, hi: float, n: int) -> np.ndarray:
    """``lo + (i + ½)(hi − lo)/n`` in float64 (the core's order), rounded once to float32."""
    return (lo + (np.arange(n) + 0.5) * ((hi - lo) / n)).astype(np.float32)


def fbm_weather_map(
    coverage: float,
    extent: Sequence[float],
    *,
    size: int = 128,
    scale: float = 2000.0,
    seed: int = 0,
    noise_version: int = DEFAULT_VERSION,
) -> np.ndarray:
    """A ``(size, size)`` float32 ``[z, x]`` weather map over ``extent`` whose mean is
    ``coverage`` (to ~1e-6; exactly 0 or 1 at the ends).

    The 2018 fBm ``f`` (:data:`MAP_FBM`, frequency ``1/(2·scale)``: its first octave's texels are
    ``scale`` world units apart) at the texel centres of the ground plane ``y = 0``, remapped as
    ``clamp((f − t)/σ + ½, 0, 1)`` with ``σ`` the standard deviation of ``f`` (soft cell edges) and
    the threshold ``t`` found by bisection so that the map's mean is ``coverage``. The lattice is
    ``seed``'s in noise version ``noise_version`` (:data:`cumuli.noise.NOISE_VERSIONS`).
    """
    coverage = check.real(coverage, "coverage", 0.0, 1.0)
    if coverage in (0.0, 1.0):
        return np.full((size, size), coverage, dtype=np.float32)
    x0, z0, x1, z1 = extent
    xs, zs = _texel_centres(x0, x1, size), _texel_centres(z0, z1, size)
    pts = np.zeros((size, size, 3), dtype=np.float32)
    pts[..., 0] = xs[None, :]
    pts[..., 2] = zs[:, None]
    f = (
        _noise(seed, noise_version)
        .fbm(pts.reshape(-1, 3), *MAP_FBM, 0.5 / scale)
        .astype(np.float64)
    )
    width = max(float(f.std()), 1e-6)

    def mean_at(t: float) -> float:
        return float(np.clip((f - t) / width + 0.5, 0.0, 1.0).mean())

    lo, hi = float(f.min()) - width, float(f.max()) + width  # mean 1 at lo, 0 at hi
    for _ in range(64):
        mid = 0.5 * (lo + hi)
        if mean_at(mid) > coverage:
            lo = mid
        else:
            hi = mid
    t = 0.5 * (lo + hi)
    return np.clip((f - t) / width + 0.5, 0.0, 1.0).astype(np.float32).reshape(size, size)


def _coverage_array(value: Any) -> np.ndarray:
    """A given weather map: 2D, real, finite, in [0, 1]; a read-only float32 copy."""
    arr = value if isinstance(value, np.ndarray) else np.asarray(value)
    if arr.dtype.kind not in "fiu":
        raise TypeError(f"coverage must be a number or a real 2D array, got dtype {arr.dtype}")
    if arr.ndim != 2:
        raise ValueError(f"coverage must be a 2D [z, x] array, got shape {arr.shape}")
    if not all(1 <= s <= MAX_MAP_EDGE for s in arr.shape):
        raise ValueError(f"coverage: each edge must be in [1, {MAX_MAP_EDGE}], got {arr.shape}")
    with np.errstate(over="ignore"):
        arr = np.array(arr, dtype=np.float32, order="C", copy=True)
    if not np.isfinite(arr).all():
        raise ValueError("coverage contains NaN or infinite values")
    if arr.min() < 0.0 or arr.max() > 1.0:
        raise ValueError(
            f"coverage values must lie in [0, 1], got [{float(arr.min())}, {float(arr.max())}]"
        )
    arr.setflags(write=False)
    return arr


def _extent(value: Any) -> tuple[float, float, float, float]:
    if isinstance(value, (str, bytes)) or not isinstance(value, Sequence) or len(value) != 4:
        raise TypeError(f"extent must be (x0, z0, x1, z1), got {value!r}")
    x0, z0, x1, z1 = (check.real(v, "extent", -check.MAX_COORD, check.MAX_COORD) for v in value)
    if not (x1 > x0 and z1 > z0):
        raise ValueError(f"extent must have x1 > x0 and z1 > z0, got {(x0, z0, x1, z1)}")
    if not (np.float32(x1) > np.float32(x0) and np.float32(z1) > np.float32(z0)):
        raise ValueError(f"extent must stay non-empty in float32, got {(x0, z0, x1, z1)}")
    return (x0, z0, x1, z1)


def _wind(value: Any) -> tuple[float, float]:
    if isinstance(value, (str, bytes)) or not isinstance(value, Sequence) or len(value) != 2:
        raise TypeError(f"wind must be two numbers (wx, wz), got {value!r}")
    wx, wz = (check.real(v, "wind", -check.MAX_COORD, check.MAX_COORD) for v in value)
    return (wx, wz)


def _resolution(value: Any) -> tuple[int, int, int]:
    if isinstance(value, (str, bytes)) or not isinstance(value, Sequence) or len(value) != 3:
        raise TypeError(f"resolution must be three ints (nx, ny, nz), got {value!r}")
    nx, ny, nz = (check.integer(v, "resolution", 2, MAX_LATTICE_EDGE) for v in value)
    if nx * ny * nz > MAX_LATTICE_VOXELS:
        raise ValueError(
            f"resolution {(nx, ny, nz)} has {nx * ny * nz} voxels, more than {MAX_LATTICE_VOXELS}"
        )
    budget.check_memory(f"a deck of resolution {(nx, ny, nz)}", _bytes((nx, ny, nz)))
    return (nx, ny, nz)


def _bytes(resolution: Sequence[int]) -> int:
    nx, ny, nz = resolution
    return nx * ny * nz * BYTES_PER_VOXEL


def dict_cost(data: Any) -> list[tuple[Any, str, int]]:
    """The memory a deck's dict implies (see :attr:`cumuli.registry.Kind.cost`): its baked
    volume and light, from ``resolution``."""
    res = data.get("resolution") if isinstance(data, dict) else None
    if not (isinstance(res, list) and len(res) == 3 and all(type(v) is int for v in res)):
        return []
    return [((id(data), "deck"), f"a deck of resolution {tuple(res)}", _bytes(res))]


@dataclass(frozen=True, eq=False)
class CloudDeck:
    """A stratus, stratocumulus or altostratus layer: the drawable of kind ``"deck"``.

    A slab from ``base`` to ``top`` (world units, +y up) over ``extent = (x0, z0, x1, z1)``. Its
    density is the model of this module's docstring: ``coverage`` is either a number in [0, 1]
    (the weather map is then :func:`fbm_weather_map` of ``map_size``² texels, features
    ``map_scale`` apart, mean ``coverage``, from ``seed``) or a 2D ``[z, x]`` array of values in
    [0, 1] over ``extent``; ``cloud_type`` (one of :data:`CLOUD_TYPES`) picks the vertical
    profile; ``density`` is the peak density; ``detail`` in [0, 1] how much the fBm (``octaves``,
    first-octave features ``detail_scale`` apart, lattice from ``seed``) erodes; the map and the
    fBm move by ``wind · time`` (``wind = (wx, wz)`` in world units per second), and with them the
    whole slab (the deck at ``time`` is the deck at time 0 translated: :meth:`still`); ``extent``
    is where the slab is at time 0. The noise lattice is
    ``seed``'s in ``noise_version`` (:data:`cumuli.noise.NOISE_VERSIONS`: the default, 2, for a new
    deck; scene files written before noise versions existed read as 1). ``sigma_t`` is
    the extinction per world unit at density 1, what the volume marcher multiplies the density
    by: the default 0.04 gives a full-coverage 700 m stratocumulus an optical depth of ~14 (a
    real overcast's 10–20). ``resolution = (nx, ny, nz)`` is the baked lattice's.

    The value is immutable; its weather map and its lattice are computed on first use and kept.
    Equality is identity, as for the other drawables.
    """

    #: Scene-file tag of this kind of drawable.
    kind: ClassVar[str] = "deck"

    base: float = 1500.0
    top: float = 2200.0
    extent: tuple[float, float, float, float] = (-8000.0, -8000.0, 8000.0, 8000.0)
    coverage: float | np.ndarray = 0.6
    cloud_type: str = "stratocumulus"
    density: float = 1.0
    sigma_t: float = 0.04
    detail: float = 0.5
    detail_scale: float = 400.0
    wind: tuple[float, float] = (0.0, 0.0)
    time: float = 0.0
    seed: int = 0
    resolution: tuple[int, int, int] = (192, 24, 192)
    map_size: int = 128
    map_scale: float = 2000.0
    octaves: int = 5
    noise_version: int = DEFAULT_VERSION
    _cache: dict[str, Any] = field(default_factory=dict, init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        s = object.__setattr__
        s(self, "base", check.real(self.base, "base", -check.MAX_COORD, check.MAX_COORD))
        s(self, "top", check.real(self.top, "top", -check.MAX_COORD, check.MAX_COORD))
        if not np.float32(self.top) > np.float32(self.base):
            raise ValueError(f"top must be greater than base, got base={self.base}, top={self.top}")
        s(self, "extent", _extent(self.extent))
        cov = self.coverage
        if isinstance(cov, (int, float, np.integer, np.floating)) and not isinstance(
            cov, (bool, np.bool_)
        ):
            s(self, "coverage", check.real(cov, "coverage", 0.0, 1.0))
        elif isinstance(cov, (bool, np.bool_, str, bytes)):
            raise TypeError(f"coverage must be a number or a 2D array, got {cov!r}")
        else:
            s(self, "coverage", _coverage_array(cov))
        if not isinstance(self.cloud_type, str) or self.cloud_type not in CLOUD_TYPES:
            raise ValueError(
                f"cloud_type must be one of {', '.join(CLOUD_TYPES)}, got {self.cloud_type!r}"
            )
        s(self, "density", check.real(self.density, "density", 0.0))
        s(self, "sigma_t", check.real(self.sigma_t, "sigma_t", 0.0, MAX_SIGMA_T))
        s(self, "detail", check.real(self.detail, "detail", 0.0, 1.0))
        s(self, "detail_scale", check.real(self.detail_scale, "detail_scale", 0.0, lo_open=True))
        s(self, "wind", _wind(self.wind))
        s(self, "time", check.real(self.time, "time"))
        s(self, "seed", check.seed(self.seed))
        s(self, "resolution", _resolution(self.resolution))
        s(self, "map_size", check.integer(self.map_size, "map_size", 2, MAP_SIZE_MAX))
        s(self, "map_scale", check.real(self.map_scale, "map_scale", 0.0, lo_open=True))
        s(self, "octaves", check.integer(self.octaves, "octaves", 1, 16))
        lo, hi = min(NOISE_VERSIONS), max(NOISE_VERSIONS)  # 1 and 2: every one between
        s(self, "noise_version", check.integer(self.noise_version, "noise_version", lo, hi))
        ox, oz = self.offset
        if not (math.isfinite(ox) and math.isfinite(oz)) or max(abs(ox), abs(oz)) > check.MAX_COORD:
            raise ValueError(
                f"wind · time must stay within ±{check.MAX_COORD:g}, got {(ox, oz)} "
                f"(wind={self.wind}, time={self.time})"
            )
        biggest = max(*(abs(v) for v in self.extent), abs(self.base), abs(self.top))
        check_fbm_reach(biggest + max(abs(ox), abs(oz)), self.detail_fbm, "extent/base/top")
        if not isinstance(self.coverage, np.ndarray):
            check_fbm_reach(max(abs(v) for v in self.extent), self._map_fbm, "extent")
        object.__setattr__(self, "_cache", {})

    # --- derived values -----------------------------------------------------------------------
    @property
    def offset(self) -> tuple[float, float]:
        """``(ox, oz) = wind · time``: how far the map and the fBm have moved."""
        return (self.wind[0] * self.time, self.wind[1] * self.time)

    def still(self) -> CloudDeck:
        """This deck at time 0: this one is it translated by ``(ox, 0, oz)`` (:attr:`offset`),
        the same medium, so it has the same lattice and light, moved. Itself when the wind has
        not moved it; made once and shared by every :meth:`at` of one deck."""
        if self.offset == (0.0, 0.0):
            return self
        if "still" not in self._cache:
            still = dataclasses.replace(self, time=0.0)
            still._cache["map"] = self.coverage_map()
            self._cache["still"] = still
        return self._cache["still"]

    @property
    def detail_fbm(self) -> tuple[int, float, float, float]:
        """The detail fBm's ``(octaves, gain, lacunarity, frequency)``."""
        freq = 1.0 / (DETAIL_LACUNARITY * self.detail_scale)
        return _fbm_params(self.octaves, DETAIL_GAIN, DETAIL_LACUNARITY, freq)

    @property
    def _map_fbm(self) -> tuple[int, float, float, float]:
        return _fbm_params(*MAP_FBM, 0.5 / self.map_scale)

    @property
    def noise(self) -> Noise:
        """The 64³ lattice of ``seed`` (in ``noise_version``) the detail (and an fBm-made map)
        come from."""
        return _noise(self.seed, self.noise_version)

    def coverage_map(self) -> np.ndarray:
        """The read-only float32 ``[z, x]`` weather map the density uses (before the wind)."""
        if "map" not in self._cache:
            if isinstance(self.coverage, np.ndarray):
                m = self.coverage
            else:
                m = fbm_weather_map(
                    self.coverage,
                    self.extent,
                    size=self.map_size,
                    scale=self.map_scale,
                    seed=self.seed,
                    noise_version=self.noise_version,
                )
                m.setflags(write=False)
            self._cache["map"] = m
        return self._cache["map"]

    def _shape(self) -> Any:
        """The core's ``DeckShape`` (built per call: it costs microseconds and is not picklable)."""
        shape = _core.DeckShape()
        shape.base, shape.top = self.base, self.top
        shape.cloud_type = self.cloud_type
        shape.density, shape.detail = self.density, self.detail
        shape.fbm = self.detail_fbm
        shape.offset = self.offset
        shape.extent = self.extent
        shape.validate()
        return shape

    def __getstate__(self) -> dict[str, Any]:
        """Pickled and copied without the memoised map and lattice (they are recomputed)."""
        return {**self.__dict__, "_cache": {}}

    # --- the drawable protocol ----------------------------------------------------------------
    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """The slab as float32 ``(lo, hi)`` (what a camera frames)."""
        return self.layer_box()

    def layer_box(self) -> tuple[np.ndarray, np.ndarray]:
        """The slab ``(x0, base, z0)``–``(x1, top, z1)`` (float32), moved by the wind's
        :attr:`offset`: all of the deck lies in it."""
        x0, z0, x1, z1 = self._moved_extent()
        return (
            np.array([x0, self.base, z0], dtype=np.float32),
            np.array([x1, self.top, z1], dtype=np.float32),
        )

    @property
    def box(self) -> tuple[tuple[float, float, float], tuple[float, float, float]]:
        """The slab as float ``(lo, hi)`` (the baked volume's box), moved by the wind."""
        x0, z0, x1, z1 = self._moved_extent()
        return ((x0, self.base, z0), (x1, self.top, z1))

    def _moved_extent(self) -> tuple[float, float, float, float]:
        """``extent`` moved by the wind's offset: where the slab is at this time."""
        (x0, z0, x1, z1), (ox, oz) = self.extent, self.offset
        return (x0 + ox, z0 + oz, x1 + ox, z1 + oz)

    def density_at(self, points: Any, threads: int = 0) -> np.ndarray:
        """ρ at ``(N, 3)`` world points: ``(N,)`` float32 (C++, the same on any thread count)."""
        pts, biggest = check.points3_magnitude(points, "points")
        check_fbm_reach(biggest + max(map(abs, self.offset)), self.detail_fbm, "points")
        return _core.deck_density(
            self._shape(), self.coverage_map(), self.noise._core, pts, check.threads(threads)
        )

    def lattice_centres(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The baked lattice's texel centres ``(xs, ys, zs)`` (float32), as the core makes them:
        ``lo + (i + ½)(hi − lo)/n`` in float64 from the float32 heights, rounded once, over the
        slab where the wind has moved it (the time-0 lattice's centres moved)."""
        x0, z0, x1, z1 = self._moved_extent()
        nx, ny, nz = self.resolution
        base, top = float(np.float32(self.base)), float(np.float32(self.top))
        return (
            _texel_centres(x0, x1, nx),
            _texel_centres(base, top, ny),
            _texel_centres(z0, z1, nz),
        )

    def density_lattice(self, threads: int = 0) -> np.ndarray:
        """ρ at the texel centres of the ``(nz, ny, nx)`` lattice over the slab: read-only
        float32 ``[z, y, x]`` (C++, parallel over z-slices, the same on any thread count; kept).
        A deck the wind has moved has its time-0 lattice, bit for bit (the same array: its
        :meth:`still`'s); its centres moved, the density there equals it to float rounding."""
        threads = check.threads(threads)
        if self.still() is not self:
            return self.still().density_lattice(threads)
        if "lattice" not in self._cache:
            out = _core.deck_lattice(
                self._shape(), self.coverage_map(), self.noise._core, self.resolution, threads
            )
            out.setflags(write=False)
            self._cache["lattice"] = out
        return self._cache["lattice"]

    def to_volume(self, threads: int = 0) -> VolumeCloud:
        """The baked deck: a :class:`VolumeCloud` of :meth:`density_lattice` over the slab with
        this deck's ``sigma_t``, read trilinearly without the volumes' detail (made once per
        deck: every stage reads the deck through it). A deck the wind has moved has its time-0
        volume's arrays over its moved box."""
        if "volume" not in self._cache and self.still() is not self:
            volume = copy.copy(self.still().to_volume(threads))  # checked fields: shared arrays
            object.__setattr__(volume, "box", self.box)
            object.__setattr__(volume, "params", {"deck": self.cloud_type, "time": self.time})
            self._cache["volume"] = volume
        if "volume" not in self._cache:
            self._cache["volume"] = VolumeCloud(
                density=self.density_lattice(threads),
                box=self.box,
                sigma_t=self.sigma_t,
                params={"deck": self.cloud_type, "time": self.time},
                # Baked from the deck's own fBm at its own resolution: read as it is.
                detail=0.0,
                reconstruction="linear",
            )
        return self._cache["volume"]

    def at(self, time: float) -> CloudDeck:
        """This deck at another ``time`` (the wind has moved it, slab, map and fBm); it shares
        the weather map, which does not depend on the time, and the time-0 deck (:meth:`still`:
        its lattice and volume, made once for every time)."""
        deck = dataclasses.replace(self, time=check.real(time, "time"))
        deck._cache["map"] = self.coverage_map()
        still = self.still()
        if deck.offset != (0.0, 0.0):
            deck._cache["still"] = still
        return deck

    # --- scene files --------------------------------------------------------------------------
    def to_dict(self) -> dict[str, Any]:
        """The deck as JSON types: an fBm-made map by its parameters, a given one as exact
        base64 float32."""
        cov = self.coverage
        return {
            "kind": self.kind,
            "base": self.base,
            "top": self.top,
            "extent": list(self.extent),
            "coverage": array_to_json(cov) if isinstance(cov, np.ndarray) else cov,
            "cloud_type": self.cloud_type,
            "density": self.density,
            "sigma_t": self.sigma_t,
            "detail": self.detail,
            "detail_scale": self.detail_scale,
            "wind": list(self.wind),
            "time": self.time,
            "seed": self.seed,
            "resolution": list(self.resolution),
            "map_size": self.map_size,
            "map_scale": self.map_scale,
            "octaves": self.octaves,
            "noise_version": self.noise_version,
        }

    @classmethod
    def from_dict(cls, data: Any, where: str = "deck") -> CloudDeck:
        """Inverse of :meth:`to_dict`; unknown fields raise ValueError naming them (missing ones
        take their defaults, but a deck without ``noise_version``, written before noise versions
        existed, reads as version 1 and so keeps its lattice)."""
        if not isinstance(data, Mapping):
            raise ValueError(f"{where} must be a JSON object, got {type(data).__name__}")
        known = {f.name for f in dataclasses.fields(cls) if f.init} | {"kind"}
        unknown = sorted(set(data) - known)
        if unknown:
            raise ValueError(f"{where} has unknown field(s): {', '.join(unknown)}")
        if data.get("kind", cls.kind) != cls.kind:
            raise ValueError(f"{where}.kind must be {cls.kind!r}, got {data['kind']!r}")
        args = {k: v for k, v in data.items() if k != "kind"}
        args.setdefault("noise_version", PAPER_VERSION)
        cov = args.get("coverage")
        if isinstance(cov, (Mapping, list)):
            args["coverage"] = array_from_json(cov, f"{where}.coverage")
        for name in ("extent", "wind", "resolution"):
            if isinstance(args.get(name), list):
                args[name] = tuple(args[name])
        try:
            return cls(**args)
        except (TypeError, ValueError) as exc:
            raise type(exc)(f"{where}: {exc}") from None

    def __repr__(self) -> str:
        cov = self.coverage
        if isinstance(cov, np.ndarray):
            coverage = f"map{cov.shape}"
        else:
            coverage = f"{cov:g} (fBm map {self.map_size}², scale {self.map_scale:g})"
        return (
            f"CloudDeck({self.cloud_type}, base={self.base:g}, top={self.top:g}, "
            f"extent={self.extent}, coverage={coverage}, density={self.density:g}, "
            f"detail={self.detail:g}, wind={self.wind}, time={self.time:g}, seed={self.seed}, "
            f"resolution={self.resolution})"
        )
