"""Where the physical mode's error lives: each reference view's sun part and sky part apart.

For every reference view (``fit_physical.views``) this renders two variants with Mitsuba 3 and
with cumuli's CPU twin and compares them on the covered 4×4 blocks (``mitsuba_views``' metric):

- ``sun``: the view's sun, the sky black (1e-6: Mitsuba's environment sampler needs a positive
  map) — the octaves and the diffused sunlight alone;
- ``sky``: the view's sky, the sun 1e-6 — the sky's light and its diffusion alone.

A view's total error is their sum weighted by each part's share of the light; a constant fitted
on totals can hide a sun part too dark behind a sky part too bright (the side-lit view: sun −6 %,
sky +11 %). Mitsuba renders on the CPU here (``scalar_rgb``: ~1–2 minutes a part at 32 samples
per pixel on two cores; the parts' block noise at 32 spp is a few per cent, their means are
good to ~1 %). Run::

    python tests/references/sun_and_sky.py [--spp 32] [--views toplit,sidelit] [--out DIR]

It prints each part's share of the light, its signed mean error and its blocks' error over the
blocks' whole light, and writes the images (``DIR/<view>_<part>_{ref,img}.npy``).

``--single`` also splits the sun's part into its single scattering and the rest: Mitsuba renders
the medium as it is (the whole phase, no δ-M scaling) with paths of two vertices, cumuli its sun
part without multiple scattering (the first order alone). It prints the single scattering's share
of the sun's light, cumuli's over Mitsuba's for the single scattering and for the rest, overall
and in the top, middle and bottom thirds of the covered rows (``single_split``).
"""

from __future__ import annotations

import argparse
import dataclasses
import sys
from collections.abc import Sequence
from pathlib import Path

import numpy as np

import cumuli as cu

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
import fit_physical as fp  # noqa: E402
import mitsuba_batch as mb  # noqa: E402
import mitsuba_views as mv  # noqa: E402

#: The radiance of a part switched off (Mitsuba samples its environment by its values).
OFF = 1e-6


def parts(scene: cu.Scene) -> dict[str, cu.Scene]:
    """The view's scene with only its sun (``"sun"``) and with only its sky (``"sky"``)."""
    sun = scene.sun
    dark = cu.Sky(zenith=(OFF,) * 3, horizon=(OFF,) * 3, ground=(OFF,) * 3, sun_disc_intensity=0.0)
    faint = cu.Sun(direction=sun.direction, colour=sun.colour, intensity=OFF)
    return {"sun": scene.replace(sky=dark), "sky": scene.replace(sun=faint)}


def reference(
    mi, name: str, scene: cu.Scene, camera: cu.Camera, spp: int, out: Path, single: bool = False
) -> np.ndarray:
    """Mitsuba's RGBA image of ``scene`` (RGB every order, alpha the coverage); ``single``: its
    single scattering, in the medium as it is (the whole phase, no δ-M scaling)."""
    mv.EXTRA_VIEWS[name] = lambda: (scene, camera)
    path = out / f"{name}.npz"
    mv.export_spec(name, path)
    spec = dict(np.load(path))
    spec["sigma_t"] = np.load(path.with_name(str(spec["field"])))["sigma_t"]
    if single:
        spec["phase"], _ = mv.phase_table(scene, keep_peak=True)
        spec["peak_share"] = 0.0
    ms = mb.render(mi, mb.build(mi, spec, "ms", spp, max_depth=2 if single else 512), spp, 1)
    t = mb.render(mi, mb.build(mi, spec, "T", 64), 64, 2)[..., 0]
    return np.concatenate([ms, 1.0 - t[..., None]], -1).astype(np.float32)


def single_scattering(scene: cu.Scene) -> cu.Scene:
    """``scene`` drawn with its first order alone (no octaves beyond it, no diffusion)."""
    return scene.replace(settings=dataclasses.replace(scene.settings, multiple_scattering=False))


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--spp", type=int, default=32)
    parser.add_argument("--views", default=",".join(fp.views()))
    parser.add_argument("--out", type=Path, default=Path("sun_and_sky"))
    parser.add_argument("--single", action="store_true", help="split the sun's single scattering")
    args = parser.parse_args(argv)
    import mitsuba as mi

    mi.set_variant("scalar_rgb")
    args.out.mkdir(parents=True, exist_ok=True)
    table = fp.views()
    for view in args.views.split(","):
        scene, camera = table[view][0]()
        images = {}
        for part, variant in parts(scene).items():
            name = f"{view}_{part}"
            ref = reference(mi, name, variant, camera, args.spp, args.out)
            img = cu.render(variant, camera, mv.WIDTH, mv.HEIGHT, backend="cpu")
            np.save(args.out / f"{name}_ref.npy", ref)
            np.save(args.out / f"{name}_img.npy", img)
            images[part] = (img, ref)
        for part, row in split_errors(images).items():
            print(f"{view:9s} {part}: share {row['share']:5.1%}  mean {row['mean']:+7.1%}  block "
                  f"error over the block's whole light: median {row['median']:6.1%}  p90 "
                  f"{row['p90']:6.1%}", flush=True)  # fmt: skip
        if args.single:
            sun = parts(scene)["sun"]
            name = f"{view}_sun_single"
            ref = reference(mi, name, sun, camera, args.spp, args.out, single=True)
            img = cu.render(single_scattering(sun), camera, mv.WIDTH, mv.HEIGHT, backend="cpu")
            np.save(args.out / f"{name}_ref.npy", ref)
            np.save(args.out / f"{name}_img.npy", img)
            for where, row in single_split(images["sun"], (img, ref)).items():
                print(f"{view:9s} sun, {where:6s}: single scattering {row['share']:5.1%} of it; "
                      f"cumuli over Mitsuba: single {row['single']:.2f}, the rest "
                      f"{row['rest']:.2f}", flush=True)  # fmt: skip
    return 0


def single_split(
    whole: tuple[np.ndarray, np.ndarray], single: tuple[np.ndarray, np.ndarray]
) -> dict[str, dict[str, float]]:
    """The sun part ``whole`` = ``(cumuli, Mitsuba)`` images split by ``single`` (their single
    scattering): over the covered blocks (``all``) and the top, middle and bottom thirds of
    their rows, the single scattering's share of Mitsuba's light and cumuli's over Mitsuba's for
    the single scattering and for the rest."""
    img, ref = (mv.blocks(a[..., :3].mean(-1)) for a in whole)
    img1, ref1 = (mv.blocks(a[..., :3].mean(-1)) for a in single)
    mask = mv.blocks(whole[1][..., 3]) >= mv.COVERED
    rows = np.flatnonzero(mask.any(axis=1))
    if rows.size < 3:
        raise ValueError("fewer than three covered rows of blocks: nothing to split")
    out = {}
    for where, picked in zip(("all", "top", "middle", "bottom"),
                             (rows, *np.array_split(rows, 3)), strict=True):  # fmt: skip
        m = np.zeros_like(mask)
        m[picked] = mask[picked]
        r, r1, c, c1 = (float(a[m].sum()) for a in (ref, ref1, img, img1))
        out[where] = {"share": r1 / r, "single": c1 / max(r1, 1e-30),
                      "rest": (c - c1) / max(r - r1, 1e-30)}  # fmt: skip
    return out


def split_errors(images: dict[str, tuple[np.ndarray, np.ndarray]]) -> dict[str, dict[str, float]]:
    """Each part's share of the reference's light on the covered blocks, its signed mean error,
    and its blocks' error over the blocks' whole light (both parts: a part that is dark in a
    block cannot have a large error there)."""
    refs = {part: mv.blocks(ref[..., :3].mean(-1)) for part, (_, ref) in images.items()}
    imgs = {part: mv.blocks(img[..., :3].mean(-1)) for part, (img, _) in images.items()}
    coverage = mv.blocks(next(iter(images.values()))[1][..., 3])
    mask = coverage >= mv.COVERED
    if not mask.any():
        raise ValueError("no block of the reference is covered: nothing to compare")
    whole = sum(refs.values())[mask]
    out = {}
    for part in images:
        a, b = imgs[part][mask], refs[part][mask]
        rel = np.abs(a - b) / np.maximum(whole, 1e-12)
        out[part] = {
            "share": float(b.sum() / whole.sum()),
            "mean": float(a.sum() / b.sum() - 1.0),
            "median": float(np.median(rel)),
            "p90": float(np.percentile(rel, 90)),
        }
    return out


if __name__ == "__main__":
    sys.exit(main())
