"""`Cloud`: a set of ellipsoid primitives plus the density model that fills them (DESIGN §4).

Primitives are numpy arrays: ``centres (N, 3)``, ``radii (N, 3)`` and ``rotations (N, 3, 3)``
(float32; a rotation's columns are the ellipsoid's axes in world space, spheres have equal radii
and the identity). The density model is ``"spheroid"`` (eq. 2, parameter κ) or ``"metaball"``
(eqs. 19–21, parameter φ and the mean squared radius r̄² of eq. 20). Once computed, the light grid
(``light``, ``[z, y, x]`` float32) and its world box (``light_box``) ride along for the renderer.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from cumuli import _validate as check

DENSITY_MODELS = ("spheroid", "metaball")
#: Most primitives a cloud may hold.
MAX_PRIMITIVES = 1 << 20


@dataclass(eq=False)
class Cloud:
    """A cloud: primitives, density model, provenance and (optionally) its light grid."""

    centres: np.ndarray
    radii: np.ndarray
    rotations: np.ndarray | None = None
    model: str = "spheroid"
    kappa: float = 0.5
    phi: float = 0.6
    stats: dict[str, Any] = field(default_factory=dict)
    params: dict[str, Any] = field(default_factory=dict)
    light: np.ndarray | None = None
    light_box: tuple[tuple[float, float, float], tuple[float, float, float]] | None = None
    #: Normalised sun direction the light grid was computed for (a different sun: stale grid).
    light_sun: tuple[float, float, float] | None = None

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
        if self.model not in DENSITY_MODELS:
            raise ValueError(f"model must be one of {DENSITY_MODELS}, got {self.model!r}")
        self.kappa = check.real(self.kappa, "kappa", 0.0, 1.0)
        self.phi = check.real(self.phi, "phi", 0.0, lo_open=True)

    # --- derived geometry -------------------------------------------------------------------
    @property
    def n(self) -> int:
        """Number of primitives."""
        return int(self.centres.shape[0])

    def __len__(self) -> int:
        return self.n

    @property
    def bbox(self) -> tuple[np.ndarray, np.ndarray]:
        """World axis-aligned bounds ``(min, max)`` of the primitives, float32 (3,) each."""
        # Half extent along world axis k of an ellipsoid: sqrt(Σ_j (R_kj r_j)²).
        half = np.sqrt(np.einsum("nkj,nj->nk", self.rotations**2, self.radii**2))
        return (
            (self.centres - half).min(axis=0).astype(np.float32),
            (self.centres + half).max(axis=0).astype(np.float32),
        )

    @property
    def centre(self) -> np.ndarray:
        """Centre of the bounding box (the LOD step measures the camera distance to it)."""
        lo, hi = self.bbox
        return ((lo + hi) / 2).astype(np.float32)

    @property
    def mean_r2(self) -> float:
        """r̄² of eq. (20): the mean squared radius (an ellipsoid counts the mean of its radii²)."""
        return float(np.mean(np.sum(self.radii.astype(np.float64) ** 2, axis=1) / 3.0))

    def core_args(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, str, float, float]:
        """The arguments the C++ core takes for a cloud."""
        return (self.centres, self.radii, self.rotations, self.model, self.kappa, self.phi)

    def __repr__(self) -> str:
        lo, hi = self.bbox
        return (
            f"Cloud(n={self.n}, model={self.model!r}, bbox=({lo.round(2).tolist()}, "
            f"{hi.round(2).tolist()}), light={'yes' if self.light is not None else 'no'})"
        )
