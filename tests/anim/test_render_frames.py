"""`cumuli demo` / `cumuli render`, render_frames and the camera paths."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

import cumuli as cu
from cumuli.anim.frames import fly_towards, orbit, render_frames
from cumuli.cli import main
from cumuli.demo import cumulus_scene


def small_scene() -> cu.Scene:
    return cumulus_scene(seed=1, settings=cu.RenderSettings(lighting="paper"))


# --- camera paths (no GL) -----------------------------------------------------------------------
def test_fly_towards_moves_in_a_line_and_looks_ahead() -> None:
    cams = fly_towards((0, 0, -50), (0, 0, 0), frames=6, stop=10)
    assert len(cams) == 6
    np.testing.assert_allclose(cams[0].position, (0, 0, -50))
    np.testing.assert_allclose(cams[-1].position, (0, 0, -10), atol=1e-9)
    steps = np.diff([c.position[2] for c in cams])
    np.testing.assert_allclose(steps, 8.0)
    for c in cams:
        np.testing.assert_allclose(c.basis()[0], (0, 0, 1), atol=1e-6)
    through = fly_towards((0, 0, -50), (0, 0, 0), frames=3, stop=-20)
    assert through[-1].position[2] == pytest.approx(20)
    with pytest.raises(ValueError, match="differ"):
        fly_towards((1, 1, 1), (1, 1, 1), frames=3)
    with pytest.raises(ValueError, match="frames"):
        fly_towards((0, 0, -5), (0, 0, 0), frames=0)


def test_orbit_circles_the_centre() -> None:
    cams = orbit((1, 2, 3), radius=10, frames=4, height=5)
    assert len(cams) == 4
    for c in cams:
        p = np.subtract(c.position, (1, 2, 3))
        assert math.isclose(math.hypot(p[0], p[2]), 10, rel_tol=1e-9)
        assert math.isclose(p[1], 5)
        assert c.target == (1.0, 2.0, 3.0)
    np.testing.assert_allclose(cams[0].position, (1, 7, -7), atol=1e-9)  # starts on −z
    # A full turn does not repeat the first frame.
    assert not np.allclose(cams[0].position, cams[-1].position)
    with pytest.raises(ValueError, match="radius"):
        orbit((0, 0, 0), radius=0, frames=3)


def test_sequences_are_exported_from_the_package(tmp_path: Path) -> None:
    # A fresh interpreter: inside pytest another test may already have imported cumuli.frames,
    # which would make the attribute appear without `import cumuli` providing it.
    import subprocess
    import sys

    code = (
        "import cumuli as cu, cumuli.anim.frames as fr\n"
        "assert cu.render_frames is fr.render_frames and cu.orbit is fr.orbit\n"
        "assert cu.fly_towards is fr.fly_towards\n"
        "assert {'render_frames', 'orbit', 'fly_towards', 'frames'} <= set(cu.__all__)\n"
    )
    res = subprocess.run(
        [sys.executable, "-c", "import cumuli as cu; cu.frames.render_frames; cu.frames.orbit"],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert res.returncode == 0, res.stderr
    res = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert res.returncode == 0, res.stderr
    # The docs' sequence example (docs/dask.md), at a tiny size on the CPU marcher.
    scene = small_scene()
    lo, hi = scene.bounds()
    centre = (lo + hi) / 2
    paths = cu.render_frames(
        scene,
        cu.orbit(centre, 40, frames=2),
        tmp_path / "out",
        width=8,
        height=6,
        backend="cpu",
        progress=False,
    )
    assert [p.name for p in paths] == ["frame_0000.png", "frame_0001.png"]
    cams = cu.fly_towards(tuple(centre + [0, 0, -60]), tuple(centre), 3, stop=-5)
    assert len(cams) == 3


# --- render_frames --------------------------------------------------------------------------------
@pytest.mark.gl
def test_render_frames_writes_numbered_images(tmp_path: Path) -> None:
    scene = small_scene()
    lo, hi = scene.bounds()
    centre = (lo + hi) / 2
    cams = fly_towards(tuple(centre + [0, 0, -60]), tuple(centre), frames=3, stop=-5)
    paths = render_frames(scene, cams, tmp_path / "seq", width=32, height=24, progress=False)
    assert [p.name for p in paths] == ["frame_0000.png", "frame_0001.png", "frame_0002.png"]
    imgs = [cu.read_image(p) for p in paths]
    assert all(i.shape == (24, 32, 4) for i in imgs)
    assert all(np.isfinite(i).all() and (i[..., 3] == 1).all() for i in imgs)
    # The last camera is inside the cloud: the frame is mostly cloud, unlike the first.
    assert not np.allclose(imgs[0], imgs[-1])
    exr = render_frames(
        scene, cams[:1], tmp_path / "exr", 16, 12, pattern="f{:02d}.exr", progress=False, alpha=True
    )
    assert exr[0].name == "f00.exr" and cu.read_image(exr[0])[..., 3].min() < 1


def test_render_frames_bad_input(tmp_path: Path) -> None:
    scene = small_scene()
    cams = orbit((0, 0, 0), 50, frames=2)
    blocker = tmp_path / "file"
    blocker.write_text("x")
    with pytest.raises(OSError, match="out_dir"):
        render_frames(scene, cams, blocker / "sub", progress=False)
    with pytest.raises(ValueError, match="pattern"):
        render_frames(scene, cams, tmp_path / "a", pattern="same.png", progress=False)
    with pytest.raises(ValueError, match="empty"):
        render_frames(scene, [], tmp_path / "b", progress=False)
    with pytest.raises(TypeError, match=r"cameras\[1\]"):
        render_frames(scene, [cams[0], "cam"], tmp_path / "c", progress=False)


# --- CLI ---------------------------------------------------------------------------------------
@pytest.mark.gl
def test_cli_demo_writes_png_and_exr(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "demo.png"
    assert main(["demo", "-o", str(out), "--width", "48", "--height", "36"]) == 0
    png, exr = cu.read_image(out), cu.read_image(tmp_path / "demo.exr")
    assert png.shape == exr.shape == (36, 48, 4)
    # The EXR holds the linear radiance; the PNG is it with the demo's exposure and tone curve.
    from cumuli.demo import DEMO_EXPOSURE, DEMO_TONEMAP

    np.testing.assert_allclose(
        cu.to_srgb8(exr, DEMO_EXPOSURE, DEMO_TONEMAP),
        cu.to_srgb8(png, exposure=1.0, tonemap="none"),
        atol=1,
    )
    assert "demo.exr" in capsys.readouterr().out


@pytest.mark.gl
def test_cli_render_scene_file(tmp_path: Path) -> None:
    scene = small_scene()
    path = scene.save(tmp_path / "scene.json")
    out = tmp_path / "img.exr"
    assert main(["render", str(path), "-o", str(out), "--size", "40x30"]) == 0
    gl = cu.read_image(out)
    assert gl.shape == (30, 40, 4) and (gl[..., 3] == 1).all()
    cpu_out = tmp_path / "cpu.exr"
    assert (
        main(["render", str(path), "-o", str(cpu_out), "--size", "40x30", "--backend", "cpu"]) == 0
    )
    # Same contract on both backends (hardware-filtered noise on GL: small differences).
    assert float(np.abs(cu.read_image(cpu_out) - gl).mean()) < 2e-3


def test_cli_render_errors(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    bad = tmp_path / "bad.json"
    bad.write_text("not json")
    assert main(["render", str(bad), "-o", str(tmp_path / "x.png")]) == 1
    assert "not valid JSON" in capsys.readouterr().err
    good = small_scene().save(tmp_path / "good.json")
    target = tmp_path / "missing" / "x.png"
    assert main(["render", str(good), "-o", str(target), "--size", "8x8"]) == 1
    assert "does not exist" in capsys.readouterr().err
    assert not target.parent.exists()
    with pytest.raises(SystemExit):
        main(["render", str(good), "-o", "x.png", "--size", "0x5"])
    assert main(["demo", "-o", str(tmp_path / "demo.jpg"), "--width", "8", "--height", "8"]) == 1
    assert "extension" in capsys.readouterr().err


def _scene() -> cu.Scene:
    return cu.Scene(
        [cu.gaussian_cumulus(n=6, seed=1)],
        noise=cu.Noise(seed=2, size=16),
        settings=cu.RenderSettings(lighting="paper"),
    )


# --- arguments that are not iterable ----------------------------------------------------------
@pytest.mark.parametrize(
    ("call", "name"),
    [
        (lambda: cu.render_frames(_scene(), 5, "out", progress=False), "cameras"),
        (lambda: cu.merge(5), "clouds"),
        (lambda: cu.fly_towards((0, 0, -10), (0, 0, 0), 3, up=None), "up"),
        (lambda: cu.orbit(5, 10, 3), "centre"),
    ],
)
def test_non_iterable_arguments_are_named(call, name: str) -> None:
    with pytest.raises(TypeError, match=name):
        call()


def test_render_frames_checks_the_pattern_before_rendering(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    from cumuli.rendering import compositor

    def never(*args: object, **kwargs: object) -> None:
        raise AssertionError("a frame was rendered")

    monkeypatch.setattr(compositor, "render", never)
    for pattern in ("{:04d}.jpg", "{:04d}", "f{:02d}.PNG.bak"):
        with pytest.raises(ValueError, match="extension"):
            render_frames(_scene(), cu.orbit((0, 0, 0), 30, 2), tmp_path, pattern=pattern,
                                  progress=False)  # fmt: skip
    assert list(tmp_path.iterdir()) == []
