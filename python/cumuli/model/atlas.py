"""Sprite atlases for billboard clouds (Torchelsen & Musse 2005 §3.2, Fig. 5; spec §3 "Textures").

[TM] textures its billboards with Wang's 16-sprite sheet, which is not redistributable; cumuli
draws a seeded sheet in C++ (``cpp/include/cumuli/model/atlas.hpp``) from its own fBm::

    α = clamp(k·(fbm(p) − t), 0, 1) · m(r),   m(r) = 1 − smoothstep(0.6, 1, r)

with α = 0 on every sprite's border, in three styles: ``"sunny"`` (white, darker bottom, some
flat-bottomed sprites), ``"rainy"`` (grey, darker, denser) and ``"wispy"`` (noise stretched along
x, elliptical mask). A `SpriteAtlas` is a straight-alpha linear RGBA image ``(H, W, 4)`` float32
(row 0 on top) cut into a grid of ``(nx, ny)`` equal cells; sprite ``i`` is the cell in column
``i mod nx``, row ``i div nx``. Any RGBA image (e.g. from `cumuli.read_image`) with its grid is an
atlas too (`SpriteAtlas.from_image`).
"""

from __future__ import annotations

import functools
from dataclasses import dataclass
from typing import Any

import numpy as np

from cumuli import _core
from cumuli._util import budget
from cumuli._util import validate as check

STYLES = ("sunny", "rainy", "wispy")
#: Most sprites a generated atlas holds, and the sprite edge range in texels.
MAX_SPRITES: int = int(_core.ATLAS_MAX_SPRITES)
MIN_SPRITE_SIZE: int = int(_core.ATLAS_MIN_SIZE)
MAX_SPRITE_SIZE: int = int(_core.ATLAS_MAX_SIZE)
#: Largest atlas image accepted (texels).
MAX_ATLAS_TEXELS = 8192 * 8192
#: Bytes per texel of an atlas image (float32 RGBA).
BYTES_PER_TEXEL = 16


@dataclass(frozen=True, eq=False)
class SpriteAtlas:
    """Sprite textures: an ``(H, W, 4)`` float32 straight-alpha RGBA image and its grid.

    ``grid = (nx, ny)`` cells of ``(W/nx) × (H/ny)`` texels; ``count`` sprites are in use (the
    first ``count`` cells, row-major from the top left). ``recipe`` says how a generated atlas
    was made (``{"style", "n", "size", "seed"}``) and is what files and scene JSON store; None for
    a user image. The image is read-only.
    """

    image: np.ndarray
    grid: tuple[int, int]
    count: int
    recipe: dict[str, Any] | None = None

    def __post_init__(self) -> None:
        img = np.asarray(self.image)
        if img.dtype.kind not in "fiu":
            raise TypeError(f"atlas image must be a real numeric array, got dtype {img.dtype}")
        if img.ndim != 3 or img.shape[2] != 4:
            raise ValueError(f"atlas image must have shape (H, W, 4), got {img.shape}")
        if img.shape[0] * img.shape[1] > MAX_ATLAS_TEXELS or img.size == 0:
            raise ValueError(f"atlas image must have 1 to {MAX_ATLAS_TEXELS} texels")
        img = np.array(img, dtype=np.float32, order="C")  # a private copy
        if not np.isfinite(img).all() or img.min() < 0.0:
            raise ValueError("atlas image must be finite and non-negative")
        if img[..., 3].max() > 1.0:
            raise ValueError("atlas image alpha must be in [0, 1]")
        if not isinstance(self.grid, (tuple, list)) or len(self.grid) != 2:
            raise TypeError(f"grid must be (nx, ny), got {self.grid!r}")
        nx = check.integer(self.grid[0], "grid", 1, img.shape[1])
        ny = check.integer(self.grid[1], "grid", 1, img.shape[0])
        if img.shape[1] % nx or img.shape[0] % ny:
            raise ValueError(
                f"grid {(nx, ny)} does not divide the image ({img.shape[1]} × {img.shape[0]})"
            )
        count = check.integer(self.count, "count", 1, nx * ny)
        img.setflags(write=False)
        object.__setattr__(self, "image", img)
        object.__setattr__(self, "grid", (nx, ny))
        object.__setattr__(self, "count", count)
        if self.recipe is not None:
            object.__setattr__(self, "recipe", dict(self.recipe))

    @classmethod
    def from_image(cls, image: Any, grid: tuple[int, int], count: int | None = None) -> SpriteAtlas:
        """A user atlas: any RGBA image (straight alpha, linear) and its ``(nx, ny)`` grid."""
        if not isinstance(grid, (tuple, list)) or len(grid) != 2:
            raise TypeError(f"grid must be (nx, ny), got {grid!r}")
        n = (
            count
            if count is not None
            else check.integer(grid[0], "grid", 1) * check.integer(grid[1], "grid", 1)
        )
        return cls(np.asarray(image), (grid[0], grid[1]), n)

    @property
    def sprite_size(self) -> tuple[int, int]:
        """Texels per sprite ``(width, height)``."""
        return (self.image.shape[1] // self.grid[0], self.image.shape[0] // self.grid[1])

    def rects(self) -> np.ndarray:
        """Texel rectangles ``(count, 4)`` float32 ``(x0, y0, x1, y1)``, row 0 on top."""
        w, h = self.sprite_size
        i = np.arange(self.count)
        x0, y0 = (i % self.grid[0]) * w, (i // self.grid[0]) * h
        return np.stack([x0, y0, x0 + w, y0 + h], axis=1).astype(np.float32)

    def uv_rects(self) -> np.ndarray:
        """The rectangles of :meth:`rects` divided by the image size: ``(u0, v0, u1, v1)``."""
        h, w = self.image.shape[:2]
        return self.rects() / np.array([w, h, w, h], dtype=np.float32)

    def sprite(self, index: int) -> np.ndarray:
        """Sprite ``index`` as a read-only ``(h, w, 4)`` view."""
        i = check.integer(index, "index", 0, self.count - 1)
        w, h = self.sprite_size
        x0, y0 = (i % self.grid[0]) * w, (i // self.grid[0]) * h
        return self.image[y0 : y0 + h, x0 : x0 + w]

    def to_dict(self) -> dict[str, Any]:
        """JSON-able: the recipe of a generated atlas, else the image as nested lists."""
        if self.recipe is not None:
            return {"recipe": dict(self.recipe)}
        return {"grid": list(self.grid), "count": self.count, "image": self.image.tolist()}

    @classmethod
    def from_dict(cls, data: Any) -> SpriteAtlas:
        """Inverse of :meth:`to_dict`."""
        if not isinstance(data, dict):
            raise TypeError(f"atlas must be an object, got {type(data).__name__}")
        if "recipe" in data:
            r = data["recipe"]
            if not isinstance(r, dict):
                raise TypeError("atlas recipe must be an object")
            unknown = set(r) - {"style", "n", "size", "seed"}
            if unknown:
                raise ValueError(f"atlas recipe has unknown keys {sorted(unknown)}")
            return sprite_atlas(**r)
        for key in ("grid", "count", "image"):
            if key not in data:
                raise ValueError(f"atlas is missing {key!r}")
        try:
            image = np.asarray(data["image"], dtype=np.float32)
        except (TypeError, ValueError) as exc:
            raise ValueError(f"atlas image is not a numeric array ({exc})") from None
        grid = data["grid"]
        if not isinstance(grid, list) or len(grid) != 2:
            raise ValueError(f"atlas grid must be [nx, ny], got {grid!r}")
        return cls(image, (grid[0], grid[1]), data["count"])

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, SpriteAtlas):
            return NotImplemented
        if self.recipe is not None or other.recipe is not None:
            return self.recipe == other.recipe
        return (
            self.grid == other.grid
            and self.count == other.count
            and np.array_equal(self.image, other.image)
        )

    def __hash__(self) -> int:
        if self.recipe is not None:
            return hash(tuple(sorted(self.recipe.items())))
        return hash((self.grid, self.count, self.image.shape))

    def __repr__(self) -> str:
        what = self.recipe if self.recipe is not None else "user image"
        return f"SpriteAtlas({self.image.shape[1]}×{self.image.shape[0]}, grid={self.grid}, {what})"


@functools.lru_cache(maxsize=32)
def _generated(style: str, n: int, size: int, seed: int) -> SpriteAtlas:
    image, grid = _core.sprite_atlas(style, n, size, seed, 0)
    recipe = {"style": style, "n": n, "size": size, "seed": seed}
    return SpriteAtlas(image, (int(grid[0]), int(grid[1])), n, recipe)


def sprite_atlas(style: str = "sunny", n: int = 16, size: int = 64, seed: int = 0) -> SpriteAtlas:
    """A seeded procedural sprite atlas (C++): ``n`` sprites of ``size²`` texels.

    ``style`` is ``"sunny"``, ``"rainy"`` or ``"wispy"``. The grid is ``nx = ceil(√n)`` by
    ``ceil(n / nx)`` (16 → 4 × 4, a ``(256, 256, 4)`` image at ``size=64``). The same arguments
    give the same (cached, read-only) atlas, bit for bit, whatever the thread count.
    """
    if not isinstance(style, str) or style not in STYLES:
        raise ValueError(f"style must be one of {STYLES}, got {style!r}")
    n = check.integer(n, "n", 1, MAX_SPRITES)
    size = check.integer(size, "size", MIN_SPRITE_SIZE, MAX_SPRITE_SIZE)
    seed = check.integer(seed, "seed", 0, 2**64 - 1)
    budget.check_memory(f"sprite_atlas(n={n}, size={size})", atlas_bytes(n, size))
    return _generated(style, n, size, seed)


def atlas_bytes(n: int, size: int) -> int:
    """Bytes of a generated atlas's image: its ``nx × ny`` grid of ``size²`` float32 RGBA
    texels (256 sprites of 512² texels: 1 GiB)."""
    nx = int(np.ceil(np.sqrt(n)))
    ny = -(-n // nx)
    return nx * ny * size * size * BYTES_PER_TEXEL


def recipes_cost(data: Any) -> list[tuple[Any, str, int]]:
    """`recipe_cost` of every ``"atlas"`` entry anywhere in the JSON value ``data`` (a weather
    file's layers, a basis model), each recipe once."""
    found: dict[Any, tuple[Any, str, int]] = {}
    stack = [data]
    while stack:
        node = stack.pop()
        if isinstance(node, dict):
            for item in recipe_cost(node.get("atlas")):
                found.setdefault(item[0], item)
            stack.extend(node.values())
        elif isinstance(node, list):
            stack.extend(node)
    return list(found.values())


def recipe_cost(atlas: Any) -> list[tuple[Any, str, int]]:
    """The cost item of an atlas dict (`SpriteAtlas.to_dict`) in a file: a recipe's image, keyed
    by the recipe (a recipe is made once however many clouds name it); nothing for a stored
    image (the file holds its bytes) or a malformed dict (building it refuses it)."""
    recipe = atlas.get("recipe") if isinstance(atlas, dict) else None
    if not isinstance(recipe, dict):
        return []
    n, size = recipe.get("n", 16), recipe.get("size", 64)
    if not all(isinstance(v, int) and not isinstance(v, bool) for v in (n, size)):
        return []
    n, size = min(max(n, 1), MAX_SPRITES), min(max(size, 1), MAX_SPRITE_SIZE)
    key = ("atlas", str(recipe.get("style")), n, size, str(recipe.get("seed")))
    return [(key, f"atlas recipe (n={n}, size={size})", atlas_bytes(n, size))]
