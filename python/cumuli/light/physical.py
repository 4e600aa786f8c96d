"""The physical mode's light step (RENDER_CONTRACT, "Physical lighting"): for one drawable, the
sun's optical depth on a lattice in the sun's frame and a world lattice of multiply scattered
and sky light, the values the physical drawers read.

The approximations, with their constants (``cpp/include/cumuli/light/physical.hpp`` has the
maths):

- **Sun, single scattering and low orders**: ``τ_sun`` on a lattice whose third axis runs along
  the light (:data:`ACROSS` nodes per world cell across it, :data:`ALONG` along it; the march
  itself in steps of at most ``light_step``), marched through the drawable's own extinction
  (the procedural density of a 2018 cloud, not a voxelisation), plus the optical depth of the
  scene's other drawables upstream of each column (clouds shade each other). The drawers add
  the first :data:`OCTAVES` scattering orders as octaves after Wrenninge, Kulla & Lundqvist
  ("Oz: the great and volumetric", SIGGRAPH 2013 talks; Hillaire 2016, "Physically based sky,
  atmosphere and cloud rendering in Frostbite"): order ``n`` scatters ``aⁿ`` of the light with
  the phase function's ``g`` scaled by ``bⁿ``, its sun light weighted by the Poisson law of
  ``n`` collisions on a path of optical depth ``β·τ``, ``(β·τ)ⁿ/n!·e^{−cⁿ·τ}``
  (:data:`OCTAVE_A`, :data:`OCTAVE_B`, :data:`OCTAVE_C`, ``β`` = :data:`OCTAVE_POISSON`): thin
  fringes draw little high-order light, the cloud's depths most of theirs, and order 0 is
  single scattering, reached by the δ-M sun (:func:`first_order_depth_scale`; :func:`octave_sum`,
  the drawers' numpy reference).
- **Multiple scattering through the cloud**: the diffusion approximation (Stam 1995) on the
  world lattice, fed by the sun's and the sky's first scattering, with Marshak's vacuum
  boundary: the light that reaches the shadowed side and the far side of the cloud. The sun's
  source takes the phase function's forward peak as unscattered (the δ-M similarity relation,
  :func:`forward_peak_share`): the sun reaches a cell with ``e^{−(1 − f·ϖ)τ}`` and ``1 − f`` of
  what collides there diffuses, a share :data:`SUN_CARRIED` of it only after it has travelled
  on along the sun's way, turning diffuse at the rate ``a·σ``, ``a = CARRIED_RATE·(1 − ϖḡ)``
  (the source ``(1 − m)e^{−kτ} + m·a/(a − k)(e^{−kτ} − e^{−aτ})`` per unit of collided light,
  :func:`carried_rate`). Its collided light is forward-scattered: :data:`SUN_FORWARD` of
  its flux source, ``−∇·(3D·Q1)`` (Ishimaru 1978, §9.2), carries it deeper along the light
  before it diffuses. The camera
  sees the first mean free path of a cell that spans several, where the diffuse light is larger
  than the cell's mean, and the whole of a cell thinner than one: the fluence is read with a
  gain that rises with the cell's optical thickness ``τc`` from 1 to :data:`SUN_GAIN`,
  ``1 + (G − 1)(1 − e^{−τc/τg})`` with ``τg`` = :data:`GAIN_DEPTH` (:func:`lattice_gains`;
  ``τc`` on the cell of the default resolution's lattice, :mod:`cumuli.light.gains`),
  and through its flux: ``anisotropy`` ``r = 3E/φ``, ``E = −D∇φ + SUN_FORWARD·3D·Q1`` (the P1
  flux with the source's first moment: the forward-scattered light streams on along the sun's
  way), applied per frame for the camera (:mod:`cumuli.light.view`, :data:`FLUX_LIMIT`).
- **Sky**: the SH projection of the visibility (order :data:`SKY_ORDER`; its rays the lattice's
  26 directions or the endless animation's quadrature with 2·:data:`SKY_SAMPLES`² of them:
  :data:`SKY_RAYS`) times the sky's SH projection gives the sky irradiance reaching each
  voxel unscattered; with multiple scattering on, it and its diffusion are read with the gain
  of the same form up to :data:`SKY_GAIN`.

The drawers see all of it through the **δ-M view**: the camera's rays take the same forward
peak as unscattered, so what lies behind a stretch of cloud reaches the camera with
``e^{−(1 − f·ϖ)τ}`` (:func:`view_depth_scale`) and the diffuse lattice light is emitted with the
share ``1 − f`` (:func:`view_diffuse_share`); the coverage (alpha) stays ``1 − e^{−τ}``.

The constants are fitted against Mitsuba 3 on the reference views of :data:`FIT_VIEWS` and
tested on the others, :data:`HELD_OUT_VIEWS` (``tests/references/fit_physical.py`` reproduces
the fit; docs/fidelity.md has the errors on every view).

Everything is a value: :class:`PhysicalLight` holds the lattices and nothing is stored on the
drawable. Computed by :func:`physical_light`, the light pass ``prepare_light`` runs for every
drawable when ``settings.lighting == "physical"``.
"""

from __future__ import annotations

import math
import time
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from cumuli import _core, registry
from cumuli.ground import ground_radiance_unshadowed
from cumuli.light.digests import drawable_digest
from cumuli.light.footprint import box_corners
from cumuli.light.gains import gain_cell, lattice_gains  # noqa: F401 (public)
from cumuli.light.medium import (  # noqa: F401 (public)
    cloud_extinction_scale,
    extinction_grid,
    fbm_args,
    march_step,
    medium_args,
    optical_depth,
)  # fmt: skip
from cumuli.light.memo import remember
from cumuli.light.moved import moved, moved_box, moved_frame, moved_light
from cumuli.light.phase import (  # noqa: F401 (public)
    PEAK_COS,
    first_order_depth_scale,
    forward_peak_share,
    order_phase_at,
    order_phase_table,
    order_phase_values,
    phase,
    phase_values,
    view_depth_scale,
    view_diffuse_share,
)
from cumuli.settings import ACROSS, ALONG, SUPERSAMPLE
from cumuli.sky import sky_args

#: Scattering orders drawn as octaves (order 0 is single scattering), and their constants:
#: order ``n`` scatters ``aⁿ`` of the light with the phase's g scaled by ``bⁿ``, weighted by
#: ``(β·τ)ⁿ/n!·e^{−cⁿ·τ}`` (``β`` = :data:`OCTAVE_POISSON`; 0 gives the plain ``e^{−cⁿ·τ}``).
OCTAVES = 2
#: How order ``n ≥ 1`` turns the light: ``"scaled"``, the phase with its g's scaled by ``bⁿ``
#: (:data:`OCTAVE_B`; Wrenninge et al.'s octaves; the constants below are fitted for it), or
#: ``"convolved"``, the δ-M phase convolved with itself ``n`` times (:func:`order_phase_table`;
#: refitted it does no better on the held-out views, docs/fidelity.md).
OCTAVE_PHASE = "scaled"
OCTAVE_A = 0.824
OCTAVE_B = 1.0
OCTAVE_C = 0.541
OCTAVE_POISSON = 0.941
#: Gains on the lattice's diffuse light, reached in optically thick cells: the sun's multiple
#: scattering, and the sky's light (:func:`lattice_gains`).
SUN_GAIN = 1.634
SKY_GAIN = 4.184
#: Optical thickness ``τg`` of a lattice cell over which the gains rise from 1 to their value.
GAIN_DEPTH = 2.159
#: Weight of the forward-scattered sun's flux source in the diffusion (``−∇·(3D·Q1)``, the first
#: moment of the collided sun light; 0: an isotropic source, 1: the whole of it).
SUN_FORWARD = 0.128
#: Share ``m`` of the collided sun light carried on along the sun's way before it diffuses, and
#: the rate at which it turns diffuse, ``a·σ`` with ``a = CARRIED_RATE·(1 − ϖḡ)`` (the reduced
#: extinction's share): the diffusion's sun source per unit of collided light is
#: ``(1 − m)·e^{−kτ} + m·a/(a − k)·(e^{−kτ} − e^{−aτ})`` (``k = 1 − f·ϖ``;
#: ``_core.lattice_transmittance``). 0: all of it diffuses where it collides.
SUN_CARRIED = 0.351
CARRIED_RATE = 1.153
#: How far the camera's view of the diffuse sun light may lean on its flux: the drawers read
#: ``φ·(1 + ḡ·clamp(r·d, ±FLUX_LIMIT))``, ``r = 3E/φ`` (:mod:`cumuli.light.view`).
FLUX_LIMIT = 0.947
#: The views the constants above were fitted on (``tests/references/fit_physical.py``); the other
#: reference views (``tests/references``) are held out to test them.
FIT_VIEWS = ("sidelit", "backlit", "metaball", "toplit", "lsystem")
HELD_OUT_VIEWS = ("sunset",)
#: The diffusion's solve: conjugate gradients preconditioned by the modified incomplete Cholesky
#: factor over the medium cells (``"mic"``; ``"jacobi"``: the diagonal, over the whole lattice),
#: to a residual of ``DIFFUSION_TOLERANCE`` of the source's.
DIFFUSION_SOLVER = "mic"
DIFFUSION_TOLERANCE = 1e-3
#: SH order of the sky visibility, its rays (``"march"``: a ray marched per voxel and direction
#: of a product quadrature; ``"lattice"``: the 26 directions to a voxel's neighbours, Lebedev's
#: 26-point rule, τ exact by one pass over the lattice per direction: 3.6 ms against the
#: march's 5–6 on the default cloud and, with the constants above fitted for it, as near or
#: nearer Mitsuba 3 on every view but the L-system's, the held-out one included:
#: docs/lighting.md) and the quadrature's polar nodes (``n_theta``: the march's, and the sky
#: radiance's projection).
SKY_ORDER = 3
SKY_RAYS = "lattice"
SKY_SAMPLES = 3
#: The sun's march along a column of its lattice ends once the optical depth passes this: the
#: sun light left is ``e^{−30}``, and the octaves' slowest term, ``β·τ·e^{−c·τ}``, ~2e-5 (the
#: nodes behind hold a depth above the cut; the Mitsuba views do not move in their 3rd digit).
SUN_DEPTH_CUT = 30.0


def check_budget(scene: Any) -> None:
    """Refuse a scene whose physical light (``settings.physical_resolution``³ nodes per
    drawable with a medium) is over the memory or work budget, before any of it is made."""
    media = sum(1 for d in scene.clouds if registry.of(d).medium is not None)
    scene.settings.check_physical_budget(media)


@dataclass(frozen=True, eq=False)
class PhysicalLight:
    """The physical light of one drawable.

    ``frame`` ``(u, v, w, lo, hi, res)``: the sun's lattice (``w`` the way light travels; node
    ``(i, j, k)`` at frame coordinates ``lo + ((i, j, k) + ½)(hi − lo)/res``, frame coordinates
    of ``p`` being ``(p·u, p·v, p·w)``); ``sun_depth`` ``(nw, nv, nu)`` its optical depths
    through the drawable itself, and ``upstream`` ``(nv, nu)`` (or None) the optical depth of the
    scene's other media upstream of each column of it, the same all along the column: the sun's
    optical depth at a node is their sum (:meth:`total_depth`; the drawers and
    :meth:`sample_depth` add them as they read, so that a shaded cloud keeps one lattice of its
    own, shared with the shadow it casts, and a map, not a second lattice);
    ``grid`` ``(D, H, W, 4)`` over ``box``: the diffuse sunlight per unit sun irradiance
    (channel 0) and the diffuse sky light (RGB), both fluences already multiplied by the gain
    the drawers use; ``octaves`` how many scattering orders the drawers draw from ``τ_sun``;
    ``shaded_from``: the drawable's own light when this one also holds the shadows of the
    scene's particle clouds and billboards (the light step's `onto_media`; a copy given back is
    replaced by it, so nothing is shaded twice), else None; ``anisotropy`` ``(D, H, W, 3)`` (or
    None without multiple scattering) ``r = 3E/φ`` of the sun's diffuse light
    (``_core.diffusion_anisotropy``), which :mod:`cumuli.light.view` turns into the camera's view
    of it; ``seen_from``: on such a view, the light it was made from (else None).
    """

    frame: tuple
    sun_depth: np.ndarray
    grid: np.ndarray
    box: tuple[tuple[float, float, float], tuple[float, float, float]]
    octaves: int
    shaded_from: PhysicalLight | None = None
    upstream: np.ndarray | None = None
    anisotropy: np.ndarray | None = None
    seen_from: PhysicalLight | None = None

    def sample_depth(self, points: Any) -> np.ndarray:
        """``τ_sun`` at world ``(N, 3)`` points (trilinear in the sun's lattice, plus the
        ``upstream`` map's bilinear value)."""
        pts = np.ascontiguousarray(points, dtype=np.float32)
        return _core.sample_frame(self.sun_depth, self.frame, pts, upstream=self.upstream)

    def total_depth(self) -> np.ndarray:
        """``(nw, nv, nu)`` float32: the sun's optical depth at every node of its lattice, the
        drawable's own plus the other media's upstream (a new array when there are any)."""
        if self.upstream is None:
            return self.sun_depth
        return self.sun_depth + self.upstream[None]

    def same_as(self, other: Any) -> bool:
        """Whether ``other`` shades alike wherever it is: the same sun axes, lattice sizes and
        orders, equal lattices (the light of a cloud the wind moved shares them, moved). The
        impostor cache asks it (a light moved with its cloud keeps the cloud's impostor)."""
        if not isinstance(other, PhysicalLight):
            return False
        self, other = self.seen_from or self, other.seen_from or other  # their camera's view aside
        if self.octaves != other.octaves:
            return False
        (u, v, w, lo, hi, res), (u2, v2, w2, lo2, hi2, res2) = self.frame, other.frame
        extent = np.subtract(hi, lo), np.subtract(hi2, lo2)
        size = np.subtract(self.box[1], self.box[0]), np.subtract(other.box[1], other.box[0])
        if (u, v, w, tuple(res)) != (u2, v2, w2, tuple(res2)):
            return False
        if not (np.allclose(*extent, rtol=1e-6) and np.allclose(*size, rtol=1e-6)):
            return False
        pairs = ((self.grid, other.grid), (self.sun_depth, other.sun_depth),
                 (self.upstream, other.upstream))  # fmt: skip
        return all(a is b or (a is not None and b is not None and a.shape == b.shape
                              and np.array_equal(a, b)) for a, b in pairs)  # fmt: skip


#: The stages :func:`physical_light` times when asked (``timings``), in the order they run.
STAGES = ("extinction", "sun_depth", "upstream", "sun_transmittance", "sky", "diffusion")


@contextmanager
def _stage(timings: dict[str, float] | None, name: str) -> Iterator[None]:
    """Adds the wall seconds of the block to ``timings[name]`` (nothing when None)."""
    t0 = time.perf_counter()
    try:
        yield
    finally:
        if timings is not None:
            timings[name] = timings.get(name, 0.0) + time.perf_counter() - t0


def physical_light(
    drawable: Any,
    scene: Any,
    threads: int = 0,
    timings: dict[str, float] | None = None,
    gain_depth: float | None = None,
    forward: float | None = None,
    upstream: list[Any] | None = None,
) -> PhysicalLight:
    """The :class:`PhysicalLight` of a drawable with a medium (a `Cloud`, a `VolumeCloud`, ...)
    under ``scene``'s sun and sky. ``timings``, a dict, receives the wall seconds of each of the
    :data:`STAGES` (added to what it holds: the benchmarks profile the light step with it).
    ``gain_depth``: the ``τg`` of :func:`lattice_gains` (None: :data:`GAIN_DEPTH`); ``forward``:
    the weight of the diffusion's forward-scattered sun source (None: :data:`SUN_FORWARD`);
    ``upstream``: the scene's drawables that shade it (None: :func:`upstream_of` its sun
    lattice; :func:`physical_pass` passes those its memo key names)."""
    medium = registry.of(drawable).medium
    if medium is None:
        raise TypeError(f"no physical light pass for {type(drawable).__name__}")
    depth_g = GAIN_DEPTH if gain_depth is None else float(gain_depth)
    if not (math.isfinite(depth_g) and depth_g >= 0.0):
        raise ValueError(f"gain_depth must be finite and >= 0, got {gain_depth}")
    weight_f = SUN_FORWARD if forward is None else float(forward)
    if not (math.isfinite(weight_f) and weight_f >= 0.0):
        raise ValueError(f"forward must be finite and >= 0, got {forward}")
    check_budget(scene)
    s = scene.settings
    n = s.physical_resolution
    lattice = medium.own_lattice(drawable)
    own = lattice is not None and max(lattice) <= n
    # A drawable the wind carries with its noise is its still self moved: its own terms are the
    # still one's (computed once for every time), only the shade of the others is where it is.
    still, offset = moved(drawable)
    # What the sun and sky do not change (the extinction lattice, the sky's visibility moments)
    # is memoised apart: a moving sun or a changing sky relights only the terms they reach.
    medium_key = ("physical medium", drawable_digest(still), scene.noise.identity, s,
                  SUPERSAMPLE)  # fmt: skip
    with _stage(timings, "extinction"):
        field = remember(
            medium_key,
            lambda: _frozen(
                extinction_grid(still, scene.noise, s, None if own else n, SUPERSAMPLE, threads)
            ),
            media=True,
        )
    lo, hi = field.box
    to_sun = scene.sun.direction
    with _stage(timings, "sun_depth"):
        still_frame, depth = own_sun_depth(still, scene, threads)
    frame = moved_frame(still_frame, offset)
    # The other drawables' shadow: their optical depth upstream of every column, from those
    # whose box the sun's lattice can see upstream (the others cast nothing on it).
    others = upstream
    if others is None:
        others = upstream_of(frame, [d for d in scene.clouds if d is not drawable])
    upstream_depth = None
    if others:
        with _stage(timings, "upstream"):
            upstream_depth = _read_only(_upstream_depth(others, scene, frame, threads))
    ext = field.values
    d, h, w = ext.shape
    with _stage(timings, "sun_transmittance"):
        lo32, cell32 = _lattice_cells(lo, hi, (w, h, d))
        # The diffusion's sun source (its only reader) with the phase's forward peak taken as
        # unscattered: e^{−(1 − f·ϖ)τ}, times the (1 − f) of the collided light that diffuses.
        peak = forward_peak_share(s) if s.multiple_scattering else 0.0
        # A share of the collided light is carried on along the light before it diffuses.
        carried = SUN_CARRIED if s.multiple_scattering else 0.0
        sun_t = _core.lattice_transmittance(
            depth, still_frame, lo32, cell32, (w, h, d), threads, upstream=upstream_depth,
            depth_scale=1.0 - peak * s.albedo, carried=carried,
            carried_rate=carried_rate(s),
        )  # fmt: skip
        if peak > 0.0:
            sun_t *= np.float32(1.0 - peak)
    sky_e = phi = aniso = None
    if s.sky_light:
        with _stage(timings, "sky"):
            visibility = remember(
                (*medium_key, "sky visibility", SKY_ORDER, SKY_SAMPLES, SKY_RAYS),
                lambda: _read_only(
                    _core.sky_visibility(
                        ext, lo, hi, SKY_ORDER, SKY_SAMPLES, 1.0, threads, method=SKY_RAYS
                    )
                ),
                media=True,
            )
            coeffs = _core.sky_sh(sky_args(scene.sky), SKY_ORDER, SKY_SAMPLES)
            sky_e = _core.sky_irradiance_from(visibility, coeffs, threads)
    octaves = 1
    if s.multiple_scattering:
        octaves = OCTAVES
        with _stage(timings, "diffusion"):
            phi = _core.diffusion_light(
                ext,
                lo,
                hi,
                sun_t,
                to_sun,
                sky_e,
                s.albedo,
                s.mean_cosine,
                DIFFUSION_TOLERANCE,
                threads,
                forward=weight_f,
                solver=DIFFUSION_SOLVER,
            )
        with _stage(timings, "diffusion"):
            aniso = _core.diffusion_anisotropy(
                ext, lo, hi, phi, s.albedo, s.mean_cosine, threads, sun_t=sun_t, to_sun=to_sun,
                forward=weight_f,
            )  # fmt: skip
            aniso.setflags(write=False)
    # A: G_sun·φ_sun; RGB: G_sky·(E_sky + φ_sky), the gains of lattice_gains (E_sky alone
    # without multiple scattering).
    # The gains' cell is the lattice's at the default resolution, whatever this one is
    # (cumuli.light.gains): a finer light does not lower them.
    grid = _core.physical_grid(
        ext, phi, sky_e, gain_cell(lo, hi, lattice), depth_g, SUN_GAIN, SKY_GAIN, threads
    )
    grid.setflags(write=False)
    return PhysicalLight(
        frame, depth, grid, moved_box((lo, hi), offset), octaves, upstream=upstream_depth,
        anisotropy=aniso,
    )  # fmt: skip


def carried_rate(settings: Any) -> float:
    """``a``: the rate, per unit of optical depth, at which the carried collided sun light turns
    diffuse, :data:`CARRIED_RATE` times the reduced extinction's share ``1 − ϖḡ`` (kept above 0:
    at ``ϖ = ḡ = 1`` nothing would ever diffuse, and the core takes only a positive rate)."""
    return max(CARRIED_RATE * (1.0 - settings.albedo * settings.mean_cosine), 1e-6)


def _read_only(fresh: np.ndarray) -> np.ndarray:
    """``fresh``, an array nothing else holds (a core result), made read-only to be memoised:
    no copy is needed, unlike :func:`_frozen`'s."""
    fresh.setflags(write=False)
    return fresh


def _frozen(value: Any) -> Any:
    """A read-only copy of ``value`` (an array, or an ``ExtinctionField``'s values), to be
    memoised: neither the memo nor a drawable's own array can then be changed through the
    other."""
    if isinstance(value, np.ndarray):
        out = value.copy()
        out.setflags(write=False)
        return out
    return value._replace(values=_frozen(np.asarray(value.values)))


def sun_frame(lo: Any, hi: Any, to_sun: Any, n: int) -> tuple:
    """The sun's lattice over the box ``[lo, hi]`` at ``physical_resolution`` ``n``: ACROSS·n
    nodes across the light, ALONG·n along it (``_core.light_frame``'s tuple)."""
    lo3, hi3 = tuple(map(float, lo)), tuple(map(float, hi))
    return _core.light_frame(lo3, hi3, to_sun, (ACROSS * n, ACROSS * n, ALONG * n))


def _frame_extent(drawable: Any, axes: np.ndarray) -> np.ndarray:
    """``(2, 3)``: the least and greatest frame coordinates (along the sun lattice's ``u, v, w``
    axes, rows of ``axes``) of the corners of ``drawable``'s box; memoised by the drawable's
    content and the axes, so that a scene's n clouds culling each other box-test in n², not
    compute n² boxes."""

    def extent() -> np.ndarray:
        blo, bhi = drawable.layer_box()
        f = box_corners(blo, bhi) @ axes.T  # (8, 3) frame coordinates
        return np.stack([f.min(axis=0), f.max(axis=0)])

    return remember(
        ("frame extent", drawable_digest(drawable), axes.tobytes()), extent, geometry=True
    )


def upstream_of(frame: tuple, drawables: Any) -> list[Any]:
    """The ``drawables`` with a medium whose box reaches the sun's lattice ``frame`` upstream:
    it overlaps the lattice's columns across the light and begins before the lattice's sun-side
    face along it. A medium is zero outside its box, so the others add nothing to the lattice's
    optical depth: culling them keeps every cloud's light step linear in the scene's clouds
    where they do not stand in each other's light."""
    u, v, w, lo, hi, _ = frame
    axes = np.array([u, v, w], np.float64)
    media = [d for d in drawables if registry.of(d).medium is not None]
    if not media:
        return []
    ext = np.stack([_frame_extent(d, axes) for d in media])  # (n, 2, 3)
    fmin, fmax = ext[:, 0], ext[:, 1]
    reach = ((fmax[:, 0] > lo[0]) & (fmin[:, 0] < hi[0]) & (fmax[:, 1] > lo[1])
             & (fmin[:, 1] < hi[1]) & (fmin[:, 2] < lo[2]))  # fmt: skip
    return [d for d, r in zip(media, reach, strict=True) if r]


def own_sun_depth(drawable: Any, scene: Any, threads: int = 0) -> tuple[tuple, np.ndarray]:
    """``(frame, τ)``: the sun's lattice over ``drawable``'s box (:func:`sun_frame`) and the
    optical depth of the drawable alone at its nodes, marched until it passes
    :data:`SUN_DEPTH_CUT`; memoised, read-only. Every drawable's lattice has the same axes (they
    follow from the sun alone), so one drawable's lattice is also the shadow it casts on the
    others (:func:`_upstream_depth`): each is marched once, whatever the clouds it shades. A
    drawable the wind carries has its still self's lattice, moved (:func:`moved`)."""
    still, offset = moved(drawable)
    if offset is not None:
        frame, depth = own_sun_depth(still, scene, threads)
        return moved_frame(frame, offset), depth
    s = scene.settings
    n = s.physical_resolution
    frame = _sun_frame_of(drawable, scene)
    step = float(min(march_step(drawable, s.light_step), (frame[4][2] - frame[3][2]) / (ALONG * n)))
    key = ("own sun depth", drawable_digest(drawable), scene.noise.identity, s, frame, step,
           SUN_DEPTH_CUT)  # fmt: skip

    def march() -> np.ndarray:
        clouds, volumes = medium_args([drawable], s)
        return _read_only(
            _core.light_space_depth(
                clouds,
                volumes,
                scene.noise._core,
                *fbm_args(s),
                frame,
                step,
                threads,
                depth_cut=SUN_DEPTH_CUT,
            )
        )

    return frame, remember(key, march)


def _upstream_depth(others: Any, scene: Any, frame: tuple, threads: int) -> np.ndarray:
    """``(nv, nu)``: the optical depth of ``others`` towards the sun from the sun-side face of
    every column of ``frame``: each one's own sun lattice (:func:`own_sun_depth`, whose axes are
    the same) read at the column's face point, trilinear, and zero across the light outside it.
    Its lattice holds the depth from its own sun-side face, so a face beyond it reads the whole
    of it, one inside it the part upstream."""
    u, v, w, lo, hi, (nu, nv, _) = frame
    fu = lo[0] + (np.arange(nu) + 0.5) * (hi[0] - lo[0]) / nu
    fv = lo[1] + (np.arange(nv) + 0.5) * (hi[1] - lo[1]) / nv
    u, v, face = np.asarray(u), np.asarray(v), lo[2] * np.asarray(w)
    out = np.zeros((nv, nu), np.float32)
    for other in others:
        other_frame, other_depth = own_sun_depth(other, scene, threads)
        # The columns within its lattice across the light: a rectangle of them (the same (u, v)
        # axes in every lattice), the columns whose u and v lie in its [lo, hi].
        (olu, olv), (ohu, ohv) = other_frame[3][:2], other_frame[4][:2]
        i0, i1 = np.searchsorted(fu, olu, "left"), np.searchsorted(fu, ohu, "right")
        j0, j1 = np.searchsorted(fv, olv, "left"), np.searchsorted(fv, ohv, "right")
        if i0 >= i1 or j0 >= j1:
            continue
        gu, gv = fu[i0:i1], fv[j0:j1]
        pts = (gu[None, :, None] * u + gv[:, None, None] * v + face).reshape(-1, 3)
        read = _core.sample_frame(other_depth, other_frame, pts.astype(np.float32), threads)
        out[j0:j1, i0:i1] += read.reshape(j1 - j0, i1 - i0)
    return out


def _lattice_cells(lo: Any, hi: Any, shape: tuple[int, int, int]) -> tuple[tuple, tuple]:
    """``(lo, cell)`` as float32 values of a ``(x, y, z)`` lattice over the box: its texel
    centres are ``lo + (index + ½)·cell`` per axis (``_core.lattice_transmittance``)."""
    lo32 = tuple(float(np.float32(lo[a])) for a in range(3))
    cell32 = tuple(float(np.float32((hi[a] - lo[a]) / shape[a])) for a in range(3))
    return lo32, cell32


def octave_sum(settings: Any, tau: Any, cos_theta: Any, octaves: int) -> np.ndarray:
    """``Σ_{n<octaves} aⁿ·phase(bⁿ·g, cos θ)·Pₙ(τ)`` (float64, ``tau`` and ``cos_theta``
    broadcast): the drawers' per-sample octave term per unit sun irradiance, ``Pₙ(τ) =
    (β·τ)ⁿ/n!·e^{−cⁿ·τ}`` with ``β`` = :data:`OCTAVE_POISSON` (``e^{−cⁿ·τ}`` when it is 0);
    the numpy reference of ``PhysicalParams.octave_sum`` and the shaders."""
    t = np.maximum(np.asarray(tau, np.float64), 0.0)
    c = np.clip(np.asarray(cos_theta, np.float64), -1.0, 1.0)
    out = np.zeros(np.broadcast_shapes(t.shape, c.shape))
    weight = np.ones_like(t)
    for n in range(octaves):
        p = order_phase(settings, c, n, octaves)
        scale = first_order_depth_scale(settings) if n == 0 else OCTAVE_C**n
        out += OCTAVE_A**n * p * weight * np.exp(-scale * t)
        if OCTAVE_POISSON > 0.0:
            weight = weight * (OCTAVE_POISSON * t) / (n + 1)
    return out


def order_phase(settings: Any, cos_theta: Any, order: int, octaves: int) -> np.ndarray:
    """Order ``order``'s phase at ``cos_theta`` as the drawers read it (:data:`OCTAVE_PHASE`;
    :func:`cumuli.light.phase.order_phase_at`)."""
    convolved = OCTAVE_PHASE == "convolved"
    return order_phase_at(settings, cos_theta, order, octaves, OCTAVE_B**order, convolved)


def octave_terms(settings: Any, cos_theta: float, octaves: int) -> list[tuple[float, float]]:
    """``(weight, c)`` of each drawn order for a ray whose direction makes ``cos_theta`` with the
    sun: weight ``aⁱ·phase(bⁱ·g)``, optical-depth scale ``cⁱ`` (the per-ray constants of the
    drawers; the Poisson weights, which depend on ``τ``, are :func:`octave_sum`'s)."""
    out = []
    for i in range(octaves):
        p = float(order_phase(settings, np.array([cos_theta]), i, octaves)[0])
        out.append((OCTAVE_A**i * p, first_order_depth_scale(settings) if i == 0 else OCTAVE_C**i))
    return out


# --- the light pass of the media in the physical mode -------------------------------------
def light_sky(scene: Any) -> Any:
    """The sky that lights the clouds: the scene's, with the ground's unshadowed radiance below
    the horizon when the scene has a ground."""
    if scene.ground is None:
        return scene.sky
    return replace(scene.sky, ground=ground_radiance_unshadowed(scene.ground, scene.sky, scene.sun))


def physical_pass(drawable: Any, scene: Any, given: Any = None, threads: int = 0) -> Any:
    """The physical mode's light pass of every kind with a medium (:func:`physical_light`),
    memoised by content; a :class:`PhysicalLight` given is used as it is."""
    if given is not None:
        if not isinstance(given, PhysicalLight):
            raise TypeError(
                f"the physical light of a drawable must be a cumuli.PhysicalLight, got "
                f"{type(given).__name__}"
            )
        # A light shaded by particles and billboards (a copy, whose registry entry is gone):
        # the drawable's own light underneath; the light step shades it again as the scene is.
        given = given.seen_from or given  # a camera's view: the light it was made from
        return given.shaded_from or given
    key, lit, upstream, sky, offset = pass_plan(drawable, scene)
    light = remember(
        key, lambda: physical_light(lit, replace(scene, sky=sky), threads, upstream=upstream)
    )
    return moved_light(light, offset) if lit is not drawable and offset is not None else light


def pass_plan(drawable: Any, scene: Any) -> tuple[tuple, Any, list[Any], Any, Any]:
    """``(key, lit, upstream, sky, offset)`` of :func:`physical_pass`: its memo key, the
    drawable it lights, the media that shade it, the sky that lights it, the wind's offset."""
    sky = light_sky(scene)
    # Only the media upstream of its sun lattice shade it (the culling of `physical_light`):
    # moving a cloud relights the clouds it shades, not every cloud of the scene.
    still, offset = moved(drawable)
    frame = moved_frame(_sun_frame_of(still, scene), offset)
    upstream = upstream_of(frame, [d for d in scene.clouds if d is not drawable])
    # Nothing shades a drawable the wind carries: its light is its still self's, alone, moved;
    # every time of it (and every copy of it) shares one light step.
    lit = still if offset is not None and not upstream else drawable
    others = tuple(drawable_digest(d) for d in upstream)
    key = ("physical", drawable_digest(lit), others, scene.noise.identity,
           scene.settings, scene.sun, sky)  # fmt: skip
    return key, lit, upstream, sky, offset


def _sun_frame_of(drawable: Any, scene: Any) -> tuple:
    """The sun lattice over ``drawable``'s box (:func:`sun_frame`), as :func:`own_sun_depth`
    places it."""
    lo, hi = (tuple(float(np.float32(v)) for v in b) for b in drawable.layer_box())
    return sun_frame(lo, hi, scene.sun.direction, scene.settings.physical_resolution)
