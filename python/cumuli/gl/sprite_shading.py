"""Per-pixel billboard shading for the shared sprite pipeline (Torchelsen & Musse 2005 §3.2
``shading="fragment"``): :class:`FragmentShading` carries what
:func:`cumuli.gl.sprites.draw_sprites_cpu` (C++ ``shade_point`` in ``rasterise_sprites``) and
:class:`cumuli.gl.sprites.SpriteLayerRenderer` (``shaders/common/billboard_shade.glsl``) evaluate at
each pixel in place of the interpolated vertex colours."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from cumuli._util import validate as check

#: Per-instance layout of the fragment-shading buffer: cloud frame 4f, y range 2f, CAF row i.
_SHADE_FORMAT = "4f 2f 1i/i"
_SHADE_ATTRS = ("in_frame", "in_yrange", "in_row")
#: Most lights and height levels of fragment shading (shaders/common/billboard_shade.glsl).
MAX_SHADE_LIGHTS = 17
MAX_SHADE_LEVELS = 16
_DIRECTIONAL = ("linear", "smoothstep")


@dataclass(frozen=True, eq=False)
class FragmentShading:
    """Per-pixel billboard shading of a :class:`Sprites` batch (Torchelsen spec §4.2,
    ``shading="fragment"``): the colour at each pixel is
    ``k_amb·ambient + H(f)·Σ_ℓ caf[k, ℓ]·D_ℓ(p)·radiance_ℓ`` at the pixel's world point ``p`` on
    sprite ``k`` (C++ ``shade_point``, GLSL ``common/billboard_shade.glsl``).

    ``frame`` ``(N, 4)``: the sprite's cloud centre ``c_C`` (world) and ``R_C``; ``yrange``
    ``(N, 2)``: its cloud's box-AABB ``y_lo, y_hi`` (world); ``caf`` ``(N, L)``; ``light_dirs``
    ``(L, 3)`` unit vectors towards the lights, ``light_radiance`` ``(L, 3)``; ``params``: the
    keys ``d_min, d_max, k_dir, directional, ambient, k_amb, height_levels``.
    """

    frame: np.ndarray
    yrange: np.ndarray
    caf: np.ndarray
    light_dirs: np.ndarray
    light_radiance: np.ndarray
    params: dict[str, Any]

    def __post_init__(self) -> None:
        dirs = np.asarray(self.light_dirs)
        n_l = dirs.shape[0] if dirs.ndim == 2 else -1
        if not 1 <= n_l <= MAX_SHADE_LIGHTS:
            raise ValueError(f"light_dirs must have shape (L, 3) with 1 <= L <= {MAX_SHADE_LIGHTS}")
        object.__setattr__(self, "light_dirs", check.float_array(dirs, "light_dirs", (n_l, 3)))
        rad = check.float_array(self.light_radiance, "light_radiance", (n_l, 3))
        object.__setattr__(self, "light_radiance", rad)
        frame = np.asarray(self.frame)
        n = frame.shape[0] if frame.ndim == 2 else -1
        object.__setattr__(self, "frame", check.float_array(frame, "frame", (n, 4)))
        object.__setattr__(self, "yrange", check.float_array(self.yrange, "yrange", (n, 2)))
        object.__setattr__(self, "caf", check.float_array(self.caf, "caf", (n, n_l)))
        p = dict(self.params)
        missing = {"d_min", "d_max", "k_dir", "directional", "ambient", "k_amb",
                   "height_levels"} - set(p)  # fmt: skip
        if missing:
            raise ValueError(f"params is missing {sorted(missing)}")
        if p["directional"] not in _DIRECTIONAL:
            raise ValueError(f"directional must be one of {_DIRECTIONAL}")
        if len(p["height_levels"]) > MAX_SHADE_LEVELS:
            raise ValueError(f"at most {MAX_SHADE_LEVELS} height levels")
        object.__setattr__(self, "params", p)

    def __len__(self) -> int:
        return int(self.frame.shape[0])

    def core_dict(self) -> dict[str, Any]:
        """The dict the C++ rasteriser takes."""
        p = self.params
        return {
            "frame": self.frame,
            "yrange": self.yrange,
            "caf": self.caf,
            "light_dirs": self.light_dirs,
            "light_radiance": self.light_radiance,
            "d_min": float(p["d_min"]),
            "d_max": float(p["d_max"]),
            "k_dir": float(p["k_dir"]),
            "directional": p["directional"],
            "ambient": tuple(float(v) for v in p["ambient"]),
            "k_amb": float(p["k_amb"]),
            "height_levels": [tuple(float(v) for v in lv) for lv in p["height_levels"]],
        }

    def uniforms(self) -> dict[str, Any]:
        """The GLSL uniforms of ``common/billboard_shade.glsl``."""
        p = self.params
        n_l = self.light_dirs.shape[0]
        dirs = np.zeros((MAX_SHADE_LIGHTS, 3), np.float32)
        rads = np.zeros((MAX_SHADE_LIGHTS, 3), np.float32)
        dirs[:n_l], rads[:n_l] = self.light_dirs, self.light_radiance
        levels = np.zeros((MAX_SHADE_LEVELS, 2), np.float32)
        lv = np.asarray(p["height_levels"], np.float32).reshape(-1, 2)
        levels[: lv.shape[0]] = lv
        # k_amb·ambient as the C++ forms it (float32 scalar times float32 vector).
        ambient = np.float32(p["k_amb"]) * np.asarray(p["ambient"], np.float32)
        return {
            "u_bb_lights": n_l,
            "u_bb_dir": [tuple(map(float, d)) for d in dirs],
            "u_bb_radiance": [tuple(map(float, r)) for r in rads],
            "u_bb_d_min": float(np.float32(p["d_min"])),
            "u_bb_d_max": float(np.float32(p["d_max"])),
            "u_bb_k_dir": float(np.float32(p["k_dir"])),
            "u_bb_directional": _DIRECTIONAL.index(p["directional"]),
            "u_bb_ambient": tuple(float(v) for v in ambient),
            "u_bb_levels": int(lv.shape[0]),
            "u_bb_level": [tuple(map(float, x)) for x in levels],
        }
