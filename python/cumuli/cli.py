"""The ``cumuli`` command: ``cumuli info``, ``cumuli demo``, ``cumuli render SCENE`` and
``cumuli --version``.

Conventions shared by the commands: an image size is ``--size WIDTHxHEIGHT`` (``--width`` and
``--height`` are kept as aliases of its two halves), ``-o/--output`` names the image (``cumuli
demo`` writes ``out.png`` when it is not given), ``-q/--quiet`` prints nothing on success, and
options that cannot go together (two figures, ``--size`` with ``--width``, an option the chosen
figure does not use) are refused with exit status 2, like any other usage error.

User errors (bad arguments, unwritable paths, a missing GL) print one ``cumuli: error: ...`` line
to stderr and exit non-zero; they never show a traceback.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import sys
from collections.abc import Sequence
from pathlib import Path

import numpy as np

#: Exit status for a user error found after argument parsing (argparse itself exits with 2).
EXIT_ERROR = 1
#: Image size when neither ``--size`` nor ``--width``/``--height`` is given.
DEFAULT_SIZE = (640, 480)
#: Seed of ``cumuli demo --noise`` and ``--torchelsen`` when ``--seed`` is not given.
DEFAULT_SEED = 7
#: Image ``cumuli demo`` writes when ``-o`` is not given.
DEFAULT_DEMO_OUTPUT = Path("out.png")


def _versions() -> dict[str, str]:
    import moderngl
    import OpenImageIO

    import cumuli

    return {
        "cumuli": cumuli.__version__,
        "python": platform.python_version(),
        "numpy": np.__version__,
        "moderngl": moderngl.__version__,
        "OpenImageIO": OpenImageIO.__version__,
    }


def _info() -> dict[str, object]:
    from cumuli import gl

    ok, text = gl.available()
    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
    return {
        **_versions(),
        "gl_available": ok,
        "gl_renderer" if ok else "gl_unavailable_reason": text,
        "threads": cores or 1,
        "shader_dir": str(gl.shader_dir()),
    }


def _cmd_info(args: argparse.Namespace) -> int:
    info = _info()
    if args.json:
        print(json.dumps(info, indent=2))
        return 0
    for key in ("cumuli", "python", "numpy", "moderngl", "OpenImageIO"):
        print(f"{key:<12} {info[key]}")
    if info["gl_available"]:
        print(f"{'GL renderer':<12} {info['gl_renderer']}")
    else:
        print(f"{'GL renderer':<12} unavailable: {info['gl_unavailable_reason']}")
    print(f"{'threads':<12} {info['threads']} (threads=0 uses all of them)")
    print(f"{'shaders':<12} {info['shader_dir']}")
    return 0


def _demo_noise(width: int, height: int, seed: int) -> np.ndarray:
    """The paper's Figures 2 and 3 side by side: a slice of the uniform lattice (left, nearest
    texels) and the same slice of its 5-octave fBm (right), from the paper's noise (version 1).
    Returns (H, W, 4) linear RGBA.
    """
    from cumuli.io.images import srgb_to_linear
    from cumuli.noise import PAPER_VERSION, Noise

    noise = Noise(seed=seed, version=PAPER_VERSION)
    half = width // 2
    size = noise.size
    # Left: the z = 0 plane of the lattice, one texel per size/half pixels, aspect kept.
    px = (np.arange(half) + 0.5) * size / half
    py = (np.arange(height) + 0.5) * size / half
    lattice = noise.lattice[0]
    left = lattice[(py.astype(int) % size)[:, None], (px.astype(int) % size)[None, :]]
    # Right: fBm on the plane z = 0.5 over the same span; octave 1 (s = 2) covers the lattice once.
    span_x = size / 2.0
    span_y = span_x * height / half
    right = noise.fbm_grid((1, height, width - half), (0.0, 0.0, 0.0), (span_x, span_y, 1.0))[0]
    values = np.concatenate([left, right], axis=1)[::-1]  # +y up in the world, row 0 on top
    # Show the values as display grey levels (as the paper's figures do): the linear pixel is the
    # one that sRGB-encodes back to the value.
    img = np.ones((height, width, 4), dtype=np.float32)
    img[..., :3] = srgb_to_linear(values)[..., None]
    return img


def _check_output(output: Path) -> None:
    """Refuse a bad output path before spending time on the render."""
    if output.suffix.lower() not in (".png", ".exr"):
        raise ValueError(f"output {str(output)!r} has an unsupported extension (use .png or .exr)")
    folder = output.parent
    if not folder.is_dir():
        raise FileNotFoundError(f"output folder {str(folder)!r} does not exist")
    if not os.access(folder, os.W_OK):
        raise PermissionError(f"output folder {str(folder)!r} is not writable")


def _write_pair(output: Path, img: np.ndarray, exposure: float, tonemap: str) -> list[Path]:
    """Write ``output`` and, beside it, the same image in the other format (PNG ↔ EXR), opaque
    (the render is already composited over the sky; its alpha is the clouds' coverage); the PNG
    with ``exposure`` and ``tonemap``, the EXR linear."""
    from cumuli.io.images import write_image

    other = output.with_suffix(".exr" if output.suffix.lower() == ".png" else ".png")
    return [write_image(p, img, exposure=exposure, tonemap=tonemap) for p in (output, other)]


def _cmd_demo(args: argparse.Namespace) -> int:
    if args.noise:
        from cumuli.io.images import write_image

        img = _demo_noise(*args.size, args.seed)
        path = write_image(args.output, img, exposure=1.0, tonemap="none")
        _say(args, f"wrote {path} ({args.size[0]}×{args.size[1]})")
        return 0
    if args.torchelsen:
        from cumuli.demo import torchelsen_sequence

        _check_output(args.output)
        img = torchelsen_sequence(*args.size, args.backend, args.seed)
        paths = _write_pair(args.output, img, *_display(args, 1.0, "none"))
        _say(args, f"wrote {' and '.join(map(str, paths))} (Torchelsen & Musse Fig. 14, CV 0 → 1)")
        return 0
    from cumuli.demo import DEMO_EXPOSURE, DEMO_TONEMAP, deck_scene, harris_scene, sunset_scene
    from cumuli.rendering.compositor import render

    _check_output(args.output)
    if args.harris:
        scene, display = harris_scene(), _display(args, 1.0, "none")
    elif args.deck:
        scene, display = deck_scene(), _display(args, DEMO_EXPOSURE, DEMO_TONEMAP)
    else:
        scene, display = sunset_scene(), _display(args, DEMO_EXPOSURE, DEMO_TONEMAP)
    w, h = args.size
    img = render(scene, scene.default_camera(), w, h, backend=args.backend)
    paths = _write_pair(args.output, img, *display)
    _say(args, f"wrote {' and '.join(map(str, paths))} ({w}×{h}, {args.backend})")
    return 0


def _say(args: argparse.Namespace, text: str) -> None:
    """Print ``text`` unless ``--quiet`` was given."""
    if not args.quiet:
        print(text)


def _size(lo: int, hi: int):
    def parse(text: str) -> tuple[int, int]:
        try:
            w, h = (int(v) for v in text.lower().split("x"))
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected WIDTHxHEIGHT, got {text!r}") from None
        if not (lo <= w <= hi and lo <= h <= hi):
            raise argparse.ArgumentTypeError(
                f"width and height must be in [{lo}, {hi}], got {text!r}"
            )
        return w, h

    return parse


def _size_args(parser: argparse.ArgumentParser, lo: int, hi: int) -> None:
    """``--size WxH`` and its aliases ``--width`` / ``--height`` (resolved by `_resolve_size`)."""
    parser.add_argument(
        "--size", type=_size(lo, hi), default=None, metavar="WxH",
        help=f"image size in pixels, WIDTHxHEIGHT, each in [{lo}, {hi}] "
        f"(default {DEFAULT_SIZE[0]}x{DEFAULT_SIZE[1]})",
    )  # fmt: skip
    parser.add_argument(
        "--width", type=_positive(lo, hi), default=None, help="alias: the W of --size"
    )
    parser.add_argument(
        "--height", type=_positive(lo, hi), default=None, help="alias: the H of --size"
    )


def _resolve_size(parser: argparse.ArgumentParser, args: argparse.Namespace) -> None:
    """Set ``args.size`` from ``--size`` or its aliases; both at once is a usage error."""
    if args.size is not None:
        if args.width is not None or args.height is not None:
            parser.error("--size cannot be combined with --width/--height (give one of them)")
        return
    args.size = (
        DEFAULT_SIZE[0] if args.width is None else args.width,
        DEFAULT_SIZE[1] if args.height is None else args.height,
    )


#: Options of ``cumuli demo`` that only some figures use, and those figures.
_DEMO_OPTION_FIGURES = {
    "seed": ("noise", "torchelsen"),
    "backend": ("default", "harris", "deck", "torchelsen"),
    "exposure": ("default", "harris", "deck", "torchelsen"),
    "tonemap": ("default", "harris", "deck", "torchelsen"),
}


def _check_demo(parser: argparse.ArgumentParser, args: argparse.Namespace) -> None:
    """Refuse options the chosen figure would ignore (a usage error, exit 2)."""
    figure = next((f for f in ("noise", "torchelsen", "harris", "deck") if getattr(args, f)), None)
    for option, figures in _DEMO_OPTION_FIGURES.items():
        if getattr(args, option) is not None and (figure or "default") not in figures:
            which = f"--{figure}" if figure else "the default demo"
            parser.error(f"--{option} is not used by {which}")
    if args.seed is None:
        args.seed = DEFAULT_SEED
    if args.backend is None:
        args.backend = "gl"


def _cmd_render(args: argparse.Namespace) -> int:
    from cumuli.io.images import display_for, write_image
    from cumuli.rendering.compositor import render
    from cumuli.scene import load_scene

    scene = load_scene(args.scene)
    if args.after:
        from cumuli.anim.frames import scene_after

        scene = scene_after(scene, args.after)
    w, h = args.size
    output = Path(args.output)
    _check_output(output)
    img = render(scene, scene.default_camera(), w, h, backend=args.backend)
    exposure, tonemap = _display(args, *display_for(scene.settings.lighting))
    alpha = "keep" if args.alpha else "opaque"
    path = write_image(output, img, alpha, exposure=exposure, tonemap=tonemap)
    _say(args, f"wrote {path} ({w}×{h}, {args.backend})")
    return 0


def _positive(lo: int, hi: int):
    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected an integer, got {text!r}") from None
        if not lo <= value <= hi:
            raise argparse.ArgumentTypeError(f"must be between {lo} and {hi}, got {value}")
        return value

    return parse


def _seed(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected an integer, got {text!r}") from None
    if not 0 <= value < 2**64:
        raise argparse.ArgumentTypeError(f"must be in [0, 2^64), got {value}")
    return value


def _display(args: argparse.Namespace, exposure: float, tonemap: str) -> tuple[float, str]:
    """The ``--exposure`` and ``--tonemap`` given, else the defaults passed."""
    return (
        exposure if args.exposure is None else args.exposure,
        tonemap if args.tonemap is None else args.tonemap,
    )


def _exposure(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number, got {text!r}") from None
    if not (value >= 0 and np.isfinite(value)):
        raise argparse.ArgumentTypeError(f"must be finite and >= 0, got {text!r}")
    return value


def _display_args(parser: argparse.ArgumentParser, exposure: str, tonemap: str) -> None:
    from cumuli.io.images import TONEMAPS

    parser.add_argument(
        "--exposure", type=_exposure, default=None,
        help=f"multiplies the linear image before the PNG's tone mapping (default {exposure})",
    )  # fmt: skip
    parser.add_argument(
        "--tonemap", choices=TONEMAPS, default=None,
        help=f"tone curve of the PNG: none clips, aces/reinhard roll highlights off "
        f"(default {tonemap}); .exr files stay linear",
    )  # fmt: skip


def build_parser() -> argparse.ArgumentParser:
    from cumuli._version import __version__

    parser = argparse.ArgumentParser(
        prog="cumuli", description="Volumetric clouds: information, demos and rendering."
    )
    parser.add_argument("--version", action="version", version=f"cumuli {__version__}")
    # Options every command takes, after its name (``cumuli demo -q``).
    common = argparse.ArgumentParser(add_help=False)
    common.add_argument("-q", "--quiet", action="store_true", help="print nothing on success")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)

    # ``info`` exists to print: it takes no --quiet.
    info = sub.add_parser("info", help="versions, GL renderer and thread count")
    info.add_argument("--json", action="store_true", help="print as JSON")
    info.set_defaults(run=_cmd_info)

    demo = sub.add_parser(
        "demo",
        parents=[common],
        help="render the demo: three cumuli at sunset, physically lit, with ground shadows",
    )
    demo.add_argument(
        "-o",
        "--output",
        default=DEFAULT_DEMO_OUTPUT,
        type=Path,
        help="image to write (.png or .exr; default out.png); the other format is written "
        "beside it",
    )
    _size_args(demo, 2, 4096)
    demo.add_argument("--backend", choices=("gl", "cpu"), default=None, help="default gl")
    # One figure per call: asking for two is an error, not a silent choice.
    figure = demo.add_mutually_exclusive_group()
    figure.add_argument(
        "--noise",
        action="store_true",
        help="instead render the noise figure (lattice | fBm, paper Figs. 2-3); one file",
    )
    demo.add_argument(
        "--seed",
        type=_seed,
        default=None,
        help=f"noise seed for --noise, weather seed for --torchelsen (default {DEFAULT_SEED})",
    )
    figure.add_argument(
        "--torchelsen",
        action="store_true",
        help="instead render Torchelsen & Musse Fig. 14: the Table 1 billboard sky at CV 0, 1/3, "
        "2/3, 1 (2x2 frames)",
    )
    figure.add_argument(
        "--harris",
        action="store_true",
        help="instead render Harris 2002 Fig. 13: particle clouds at sunset under two coloured "
        "lights (orange sun, pink light)",
    )
    figure.add_argument(
        "--deck",
        action="store_true",
        help="instead render a stratocumulus deck over a plain (a CloudDeck, physically lit)",
    )
    _display_args(
        demo, "0.8; 1 with --harris, --torchelsen", "aces; none with --harris, --torchelsen"
    )
    demo.set_defaults(run=_cmd_demo, check=_check_demo)

    rend = sub.add_parser(
        "render", parents=[common], help="render a scene file written by Scene.save"
    )
    rend.add_argument("scene", type=Path, help="scene JSON")
    rend.add_argument("-o", "--output", required=True, type=Path, help="image (.png or .exr)")
    _size_args(rend, 1, 16384)
    rend.add_argument("--backend", choices=("gl", "cpu"), default="gl", help="default gl")
    rend.add_argument(
        "--after",
        type=float,
        default=0.0,
        metavar="SECONDS",
        help="render the scene this many seconds later: what moves by itself (a deck's wind, "
        "a cloud's) moved on",
    )
    rend.add_argument(
        "--alpha",
        action="store_true",
        help="keep the clouds' coverage (1 - T) as alpha instead of writing an opaque image",
    )
    _display_args(rend, "0.8, or 1 for a paper-mode scene", "aces, or none for a paper-mode scene")
    rend.set_defaults(run=_cmd_render)
    for command in (demo, rend):
        command.set_defaults(parser=command)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``cumuli`` console script; returns the exit status."""
    parser = build_parser()
    args = parser.parse_args(argv)
    if hasattr(args, "size"):
        _resolve_size(args.parser, args)
    if hasattr(args, "check"):
        args.check(args.parser, args)
    try:
        return int(args.run(args))
    except (ValueError, TypeError, OSError, RuntimeError) as exc:
        print(f"cumuli: error: {exc}", file=sys.stderr)
        return EXIT_ERROR
    except KeyboardInterrupt:
        print("cumuli: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
