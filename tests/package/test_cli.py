"""The `cumuli` command, run as a subprocess the way a user runs it."""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import cumuli as cu
from cumuli import cli


def _env() -> dict[str, str]:
    # The child sees exactly this interpreter's import path (in-tree PYTHONPATH=python runs and
    # editable installs alike).
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join(p for p in sys.path if p)
    return env


def run(*args: str, cwd: Path | None = None) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "cumuli", *args],
        capture_output=True,
        text=True,
        timeout=120,
        env=_env(),
        cwd=cwd,
    )


def test_info_prints_versions_renderer_and_threads() -> None:
    res = run("info")
    assert res.returncode == 0, res.stderr
    out = res.stdout
    for key in ("cumuli", "numpy", "moderngl", "OpenImageIO", "GL renderer", "threads"):
        assert key in out
    assert cu.__version__ in out and np.__version__ in out


def test_info_json() -> None:
    res = run("info", "--json")
    assert res.returncode == 0, res.stderr
    info = json.loads(res.stdout)
    assert info["cumuli"] == cu.__version__
    assert isinstance(info["threads"], int) and info["threads"] >= 1
    if info["gl_available"]:
        assert info["gl_renderer"]
    else:
        assert info["gl_unavailable_reason"]


def test_demo_writes_the_noise_image(tmp_path: Path) -> None:
    res = run(
        "demo", "--noise", "-o", str(tmp_path / "demo.png"), "--width", "96", "--height", "40"
    )
    assert res.returncode == 0, res.stderr
    img = cu.read_image(tmp_path / "demo.png")
    assert img.shape == (40, 96, 4)
    left, right = img[..., :48, 0], img[..., 48:, 0]
    # Left: raw lattice (wide spread); right: fBm (narrower), as in the paper's Figs. 2 and 3.
    assert left.std() > 2 * right.std() > 0
    np.testing.assert_array_equal(img[..., 3], 1.0)


def test_demo_image_matches_the_function_it_calls(tmp_path: Path) -> None:
    path = tmp_path / "demo.exr"
    args = ["demo", "--noise", "-o", str(path), "--width", "32", "--height", "16", "--seed", "3"]
    assert cli.main(args) == 0
    np.testing.assert_array_equal(cu.read_image(path), cli._demo_noise(32, 16, 3))


def test_the_noise_figure_draws_the_papers_noise(monkeypatch: pytest.MonkeyPatch) -> None:
    import cumuli.noise as cnoise

    made: list[cu.Noise] = []

    class Spy(cnoise.Noise):
        def __init__(self, *args: object, **kwargs: object) -> None:
            super().__init__(*args, **kwargs)  # type: ignore[arg-type]
            made.append(self)

    monkeypatch.setattr(cnoise, "Noise", Spy)
    cli._demo_noise(32, 16, 3)
    assert [n.identity for n in made] == [(3, 64, cnoise.PAPER_VERSION)]  # Figs. 2-3: the table


@pytest.mark.parametrize(
    ("args", "code", "message"),
    [
        (["demo", "-o", "x.png", "--width", "abc"], 2, "--width"),
        (["demo", "-o", "x.png", "--height", "0"], 2, "--height"),
        (["demo", "-o", "x.png", "--seed", "-4"], 2, "--seed"),
        (["demo", "--size", "64"], 2, "WIDTHxHEIGHT"),
        (["demo", "--size", "1x8"], 2, "[2, 4096]"),
        (["demo", "--size", "64x48", "--width", "32"], 2, "cannot be combined"),
        (["demo", "--harris", "--torchelsen"], 2, "not allowed with"),
        (["demo", "--noise", "--deck"], 2, "not allowed with"),
        (["demo", "--seed", "3"], 2, "--seed is not used by the default demo"),
        (["demo", "--harris", "--seed", "3"], 2, "--seed is not used by --harris"),
        (["demo", "--noise", "--backend", "cpu"], 2, "--backend is not used by --noise"),
        (["demo", "--noise", "--exposure", "2"], 2, "--exposure is not used by --noise"),
        (["render", "s.json", "-o", "x.png", "--size", "8x8", "--height", "4"], 2, "combined"),
        (["info", "--quiet"], 2, "unrecognized arguments"),
        (["frobnicate"], 2, "invalid choice"),
        ([], 2, "required"),
        (["demo", "-o", "x.jpg"], 1, "extension"),
        (["demo", "-o", "no/such/folder/x.png"], 1, "does not exist"),
    ],
)
def test_bad_arguments_give_a_clear_error(
    tmp_path: Path, args: list[str], code: int, message: str
) -> None:
    res = run(*args, cwd=tmp_path)
    assert res.returncode == code
    assert message in res.stderr
    assert "Traceback" not in res.stderr + res.stdout
    assert list(tmp_path.iterdir()) == []


def test_render_after_moves_the_windy_clouds(tmp_path: Path) -> None:
    base = cu.gaussian_cumulus(n=8, seed=3)
    windy = cu.Cloud(base.centres, base.radii, wind=(4.0, 0.0))
    camera = cu.Camera((0.0, 2.0, -50.0), (0.0, 0.0, 0.0), fov=40)
    scene = cu.Scene([windy], noise=cu.Noise(seed=2, size=32), camera=camera)
    scene.save(tmp_path / "s.json")
    res = run("render", "s.json", "-o", "later.exr", "--size", "40x30", "--backend", "cpu",
              "--after", "2.5", cwd=tmp_path)  # fmt: skip
    assert res.returncode == 0, res.stderr
    later = cu.read_image(tmp_path / "later.exr")
    want = cu.render(scene.replace(clouds=[windy.at(2.5)]), camera, 40, 30, backend="cpu")
    np.testing.assert_allclose(later[..., :3], want[..., :3], atol=1e-5)
    assert np.abs(later - cu.read_image(_render_now(tmp_path))).max() > 1e-3  # it moved
    res = run("render", "s.json", "-o", "x.png", "--after", "nan", cwd=tmp_path)
    assert res.returncode == 1 and "seconds" in res.stderr and not (tmp_path / "x.png").exists()


def _render_now(folder: Path) -> Path:
    res = run("render", "s.json", "-o", "now.exr", "--size", "40x30", "--backend", "cpu",
              cwd=folder)  # fmt: skip
    assert res.returncode == 0, res.stderr
    return folder / "now.exr"


def test_demo_writes_out_png_by_default_and_quiet_prints_nothing(tmp_path: Path) -> None:
    res = run("demo", "--noise", "--size", "40x20", "--quiet", cwd=tmp_path)
    assert res.returncode == 0, res.stderr
    assert res.stdout == "" and res.stderr == ""
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out.png"]
    assert cu.read_image(tmp_path / "out.png").shape == (20, 40, 4)
    loud = run("demo", "--noise", "--size", "40x20", "-o", "n.png", cwd=tmp_path)
    assert loud.returncode == 0 and "wrote" in loud.stdout and "40×20" in loud.stdout


@pytest.mark.parametrize(
    "size_args", [["--size", "36x18"], ["--width", "36", "--height", "18"], ["--size", "36X18"]]
)
def test_size_and_its_width_height_aliases_agree(tmp_path: Path, size_args: list[str]) -> None:
    path = tmp_path / "n.exr"
    assert cli.main(["demo", "--noise", "-q", "-o", str(path), *size_args]) == 0
    np.testing.assert_array_equal(cu.read_image(path), cli._demo_noise(36, 18, cli.DEFAULT_SEED))


def test_one_alias_keeps_the_default_of_the_other(tmp_path: Path) -> None:
    path = tmp_path / "n.exr"
    assert cli.main(["demo", "--noise", "-q", "-o", str(path), "--width", "30"]) == 0
    assert cu.read_image(path).shape == (cli.DEFAULT_SIZE[1], 30, 4)


def test_every_image_command_takes_the_same_size_and_quiet_options() -> None:
    parser = cli.build_parser()
    (commands,) = [a for a in parser._actions if isinstance(a, argparse._SubParsersAction)]
    for name in ("demo", "render"):
        options = {s for a in commands.choices[name]._actions for s in a.option_strings}
        assert {"--size", "--width", "--height", "-q", "--quiet", "-o", "--output"} <= options
