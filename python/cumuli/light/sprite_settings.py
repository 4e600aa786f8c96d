"""Settings of Harris 2002's particle light and eye passes (spec §9): :class:`SpriteSettings`,
frozen and validated, with the ``"paper"`` (default) and ``"skyworks"`` presets."""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import asdict, dataclass, fields, replace
from typing import Any

import numpy as np

from cumuli._util import validate as check

PHASES = ("rayleigh", "isotropic", "hg")
KERNELS = ("gaussian", "hermite")
READBACKS = ("pixel", "bilinear", "solid_angle")
SORTS = ("distance", "depth")
METHODS = ("cpu", "gl", "readback")
PRESETS = ("paper", "skyworks")
#: Per-particle τ and albedo of the presets (particle data, not settings: pass them to the
#: generators, e.g. ``particle_fill(..., tau=PRESET_PARTICLES["skyworks"]["tau"])``).
PRESET_PARTICLES = {"paper": {"tau": 8.0, "albedo": 0.9}, "skyworks": {"tau": 80.0, "albedo": 0.9}}
#: Most lights of one light pass.
MAX_LIGHTS = 1024


@dataclass(frozen=True)
class SpriteSettings:
    """Settings of the Harris particle passes (spec §4, §5, §9); frozen and validated.

    Attributes
    ----------
    solid_angle:
        γ of ``g = a τ p γ I/4π`` (sr). [H] omits it (1.0, the default); SkyWorks 0.09; the 2018
        paper quotes Harris with 1e−4.
    phase, hg_g:
        ``"rayleigh"`` ([H]: ¾(1 + cos²θ)), ``"isotropic"`` ([H] Fig. 12) or ``"hg"`` with
        asymmetry ``hg_g`` in (−1, 1); all normalised to 4π as in [H].
    kernel, peak:
        Splat kernel ``K(d) = peak·k(d)``: ``"gaussian"`` (windowed, σ = 1/3 [decision]) or
        ``"hermite"`` (SkyWorks ``1 − 3d² + 2d³``); peak in (0, 1].
    light_resolution:
        N_L of the light buffer, in [8, 4096] (SkyWorks: 32).
    readback:
        ``"pixel"`` ([H]: the pixel under the centre), ``"bilinear"`` (continuous in position) or
        ``"solid_angle"`` (SkyWorks: mean over a patch subtending ``readback_solid_angle``).
    readback_solid_angle:
        γ_r of that patch (sr), default 0.09 [decision: a separate field, so that the paper's
        γ = 1 does not make the patch the whole buffer].
    forward:
        False drops forward scattering (g = 0): [H] Fig. 10's single scattering.
    clamp, quantize:
        2002 emulation: clamp the buffer to [0, 1] after each blend; ``quantize=8`` rounds it to
        1/255 (and clamps) after each blend. Defaults float32, no clamp.
    allow_gain:
        Accept ``a τ p_fwd γ/4π > 1 − e^{−τ}`` (a particle adding light); otherwise
        :func:`particle_light` raises ``ValueError`` naming ``solid_angle``.
    ambient:
        RGB added to every particle's colour in the eye pass (SkyWorks 0.3).
    sort:
        Eye-pass order key: ``"distance"`` |p − eye| ([H] Fig. 4) or ``"depth"`` (p − eye)·f
        (SkyWorks; what impostor splitting uses).
    near:
        Sprites whose centre has view depth ≤ near are skipped.
    relight_tolerance:
        Degrees a light may turn before :func:`light_is_stale` calls the light stale.
    """

    solid_angle: float = 1.0
    phase: str = "rayleigh"
    hg_g: float = 0.6
    kernel: str = "gaussian"
    peak: float = 1.0
    light_resolution: int = 32
    readback: str = "pixel"
    readback_solid_angle: float = 0.09
    forward: bool = True
    clamp: bool = False
    quantize: int = 0
    allow_gain: bool = False
    ambient: tuple[float, float, float] = (0.0, 0.0, 0.0)
    sort: str = "distance"
    near: float = 1e-3
    relight_tolerance: float = 1e-6

    def __post_init__(self) -> None:
        def put(name: str, value: Any) -> None:
            object.__setattr__(self, name, value)

        put(
            "solid_angle",
            check.real(self.solid_angle, "solid_angle", 0.0, 4 * math.pi, lo_open=True),
        )
        for name, allowed in (
            ("phase", PHASES),
            ("kernel", KERNELS),
            ("readback", READBACKS),
            ("sort", SORTS),
        ):
            value = getattr(self, name)
            if value not in allowed:
                raise ValueError(f"{name} must be one of {allowed}, got {value!r}")
        put("hg_g", check.real(self.hg_g, "hg_g", -1.0, 1.0, lo_open=True, hi_open=True))
        put("peak", check.real(self.peak, "peak", 0.0, 1.0, lo_open=True))
        put("light_resolution", check.integer(self.light_resolution, "light_resolution", 8, 4096))
        put(
            "readback_solid_angle",
            check.real(
                self.readback_solid_angle, "readback_solid_angle", 0.0, 4 * math.pi, lo_open=True
            ),
        )
        for name in ("forward", "clamp", "allow_gain"):
            if not isinstance(getattr(self, name), (bool, np.bool_)):
                raise TypeError(f"{name} must be a bool, got {type(getattr(self, name)).__name__}")
            put(name, bool(getattr(self, name)))
        quantize = check.integer(self.quantize, "quantize", 0, 8)
        if quantize not in (0, 8):
            raise ValueError(f"quantize must be 0 (float) or 8 (8-bit buffer), got {quantize}")
        put("quantize", quantize)
        put("ambient", check.radiance(self.ambient, "ambient"))
        put("near", check.real(self.near, "near", 0.0, 1e6, lo_open=True))
        put(
            "relight_tolerance", check.real(self.relight_tolerance, "relight_tolerance", 0.0, 180.0)
        )

    @classmethod
    def preset(cls, name: str = "paper", **changes: Any) -> SpriteSettings:
        """``"paper"`` ([H], the defaults) or ``"skyworks"`` (Harris's SkyWorks code: Hermite
        kernel ×0.4, γ = 0.09 over a solid-angle read-back patch, clamped buffer, ambient 0.3,
        depth sort), with ``changes`` applied on top."""
        if name == "paper":
            base = cls()
        elif name == "skyworks":
            base = cls(
                solid_angle=0.09,
                kernel="hermite",
                peak=0.4,
                readback="solid_angle",
                clamp=True,
                ambient=(0.3, 0.3, 0.3),
                sort="depth",
            )
        else:
            raise ValueError(f"preset must be one of {PRESETS}, got {name!r}")
        return replace(base, **changes)

    def light_dict(self) -> dict[str, Any]:
        """The light-pass fields, as the C++ core and the GL twins take them."""
        keys = (
            "light_resolution",
            "solid_angle",
            "phase",
            "hg_g",
            "kernel",
            "peak",
            "readback",
            "readback_solid_angle",
            "forward",
            "clamp",
            "quantize",
            "allow_gain",
        )
        return {k: getattr(self, k) for k in keys}

    def to_dict(self) -> dict[str, Any]:
        """JSON-able fields (scene files)."""
        d = asdict(self)
        d["ambient"] = list(self.ambient)
        return d

    @classmethod
    def from_dict(cls, doc: Mapping[str, Any]) -> SpriteSettings:
        """Settings from :meth:`to_dict` output; unknown keys raise ValueError."""
        if not isinstance(doc, Mapping):
            raise TypeError(f"sprite settings must be a mapping, got {type(doc).__name__}")
        known = {f.name for f in fields(cls)}
        unknown = set(doc) - known
        if unknown:
            raise ValueError(f"unknown sprite settings {sorted(unknown)}")
        values = dict(doc)
        if "ambient" in values:
            values["ambient"] = tuple(values["ambient"])
        return cls(**values)


def as_settings(settings: SpriteSettings | None) -> SpriteSettings:
    """``settings``, or the defaults for None (TypeError for anything else)."""
    if settings is None:
        return SpriteSettings()
    if not isinstance(settings, SpriteSettings):
        raise TypeError(f"settings must be a SpriteSettings, got {type(settings).__name__}")
    return settings
