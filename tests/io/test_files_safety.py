"""No lost files: verified writes on a full disk, temporaries that
no glob of the real extension finds and that fit NAME_MAX, cleanup on SIGTERM, the file mode and
symlinks kept by the atomic replace, bounded memory in read_image / write_image, the alpha of
saved images.
"""

from __future__ import annotations

import fnmatch
import functools
import os
import signal
import stat
import struct
import subprocess
import sys
import textwrap
import tracemalloc
import zlib
from collections.abc import Callable, Iterator
from pathlib import Path

import numpy as np
import pytest

import cumuli as cu
import cumuli.io.images as cio
from cumuli._util import atomic as _atomic

ROOT = Path(__file__).resolve().parents[2]


def _noisy(h: int, w: int, seed: int = 0) -> np.ndarray:
    """An image PNG and EXR cannot compress much (random bytes)."""
    img = np.random.default_rng(seed).uniform(0, 1, (h, w, 4)).astype(np.float32)
    img[..., 3] = 1.0
    return img


def _cloud() -> cu.Cloud:
    return cu.gaussian_cumulus(n=6, seed=1)


@functools.cache
def _big_image() -> np.ndarray:
    big = _noisy(400, 400, seed=5)  # ~0.5 MB as PNG, ~2.5 MB as EXR
    return np.concatenate([big, big[::-1], big[:, ::-1]], axis=0)  # PNG > 1.4 MB: beyond the disk


@functools.cache
def _big_cloud(n: int) -> cu.Cloud:
    """120 000 primitives are > 1 MiB as .npz, 12 000 > 1 MiB as JSON."""
    return cu.Cloud(np.random.default_rng(1).uniform(-50, 50, (n, 3)), np.ones(n))


def _savers() -> dict[str, Callable[[Path], object]]:
    """Savers of files larger than the 1 MiB disk (their data made on first use)."""
    return {
        "a.png": lambda p: cu.write_image(p, _big_image(), exposure=1.0, tonemap="none"),
        "a.exr": lambda p: cu.write_image(p, _big_image(), exposure=1.0, tonemap="none"),
        "c.npz": lambda p: _big_cloud(120_000).save(p),
        "c.json": lambda p: _big_cloud(12_000).save(p),
        "s.json": lambda p: cu.Scene(
            [_big_cloud(12_000)], settings=cu.RenderSettings(lighting="paper")
        ).save(p),
    }


def _small(name: str, path: Path) -> None:
    if name.endswith((".png", ".exr")):
        cu.write_image(path, _noisy(8, 8, seed=2), exposure=1.0, tonemap="none")
    elif name.startswith("s"):
        cu.Scene([_cloud()], settings=cu.RenderSettings(lighting="paper")).save(path)
    else:
        _cloud().save(path)


# --- full disk (item 2) -------------------------------------------------------------------------
@pytest.fixture
def small_disk(tmp_path: Path) -> Iterator[Path]:
    """A 1 MiB tmpfs (needs root, as in the issue's experiment)."""
    disk = tmp_path / "disk"
    disk.mkdir()
    done = subprocess.run(
        ["mount", "-t", "tmpfs", "-o", "size=1m", "tmpfs", str(disk)], capture_output=True
    )
    if done.returncode != 0:
        pytest.skip(f"cannot mount a tmpfs here: {done.stderr.decode().strip()}")
    try:
        yield disk
    finally:
        subprocess.run(["umount", str(disk)], check=True)


@pytest.mark.parametrize("name", ["a.png", "a.exr", "c.npz", "c.json", "s.json"])
def test_a_full_disk_raises_and_keeps_the_old_file(small_disk: Path, name: str) -> None:
    target = small_disk / name
    _small(name, target)
    old = target.read_bytes()
    with pytest.raises(OSError):
        _savers()[name](target)
    assert target.read_bytes() == old
    assert sorted(p.name for p in small_disk.iterdir()) == [name]


@pytest.mark.parametrize("ext", [".png", ".exr"])
def test_a_short_write_the_writer_did_not_report_is_caught(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, ext: str
) -> None:
    # What OpenImageIO's PNG writer did on a full disk: report success for a truncated file.
    target = tmp_path / f"a{ext}"
    old_img = _noisy(16, 16, seed=1)
    cu.write_image(target, old_img, exposure=1.0, tonemap="none")
    old = target.read_bytes()
    real = cio._write_with_oiio

    def short(tmp: Path, *args: object) -> None:
        real(tmp, *args)
        size = tmp.stat().st_size
        with open(tmp, "r+b") as fh:
            fh.truncate(size - size // 3)

    monkeypatch.setattr(cio, "_write_with_oiio", short)
    with pytest.raises(OSError, match="read back"):
        cu.write_image(target, _noisy(32, 32, seed=3), exposure=1.0, tonemap="none")
    assert target.read_bytes() == old
    assert [p.name for p in tmp_path.iterdir()] == [target.name]


# --- temporary names (item 4) -------------------------------------------------------------------
def _temporaries_seen_while_writing(
    monkeypatch: pytest.MonkeyPatch, write: Callable[[], object]
) -> list[str]:
    seen: list[str] = []
    real = os.replace

    def spy(src: object, dst: object) -> None:
        seen.append(Path(os.fsdecode(src)).name)
        real(src, dst)

    monkeypatch.setattr(os, "replace", spy)
    write()
    return seen


@pytest.mark.parametrize("name", ["a.png", "a.exr", "c.npz", "c.json", "s.json", "g.npz"])
def test_no_glob_of_the_real_extension_matches_a_temporary(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, name: str
) -> None:
    target = tmp_path / name
    if name == "g.npz":
        grid = cu.light_grid(_cloud(), cu.Sun(), cu.Noise(seed=1, size=8), resolution=4)
        write: Callable[[], object] = lambda: grid.save(target)  # noqa: E731
    else:
        write = lambda: _small(name, target)  # noqa: E731
    (tmp_name,) = _temporaries_seen_while_writing(monkeypatch, write)
    ext = Path(name).suffix
    assert tmp_name.startswith(".")
    for pattern in (f"*{ext}", f".*{ext}", f"*{ext.upper()}", f"{Path(name).stem}*{ext}"):
        assert not fnmatch.fnmatch(tmp_name, pattern), (tmp_name, pattern)
    assert list(tmp_path.glob(f"*{ext}")) == [target]


@pytest.mark.parametrize("length", [240, 255])
@pytest.mark.parametrize("ext", [".png", ".exr", ".npz", ".json"])
def test_names_up_to_name_max_can_be_written(tmp_path: Path, length: int, ext: str) -> None:
    name_max = os.pathconf(tmp_path, "PC_NAME_MAX")
    assert name_max >= length
    name = "é" * ((length - len(ext)) // 2) + "x" * ((length - len(ext)) % 2) + ext
    assert len(name.encode()) == length
    target = tmp_path / name
    _small(name if ext in (".png", ".exr") else "c" + ext, target)
    assert [p.name for p in tmp_path.iterdir()] == [name]


# --- SIGTERM (item 4) ---------------------------------------------------------------------------
_KILLED_SCRIPT = """
import os, sys, time
from pathlib import Path
import numpy as np
import cumuli as cu

target = Path(sys.argv[1])
real = os.replace


def slow(src, dst):
    print("TEMP", Path(os.fsdecode(src)).name, flush=True)
    time.sleep(60)  # killed here: the temporary is complete but not renamed
    real(src, dst)


os.replace = slow
if target.suffix in (".png", ".exr"):
    cu.write_image(target, np.random.default_rng(0).uniform(0, 1, (64, 64, 4)))
elif target.name.startswith("s"):
    cu.Scene([cu.gaussian_cumulus(n=6, seed=3)]).save(target)
else:
    cu.gaussian_cumulus(n=6, seed=3).save(target)
"""


@pytest.mark.parametrize("name", ["a.exr", "a.png", "c.npz", "c.json", "s.json"])
def test_sigterm_during_a_save_leaves_no_temporary(tmp_path: Path, name: str) -> None:
    folder = tmp_path / "out"
    folder.mkdir()
    target = folder / name
    _small(name, target)
    old = target.read_bytes()
    script = tmp_path / "save.py"
    script.write_text(textwrap.dedent(_KILLED_SCRIPT))
    proc = subprocess.Popen(
        [sys.executable, str(script), str(target)], stdout=subprocess.PIPE, text=True
    )
    try:
        line = proc.stdout.readline()
        assert line.startswith("TEMP "), line
        assert (folder / line.split()[1]).exists()
        proc.send_signal(signal.SIGTERM)
        proc.wait(timeout=30)
    finally:
        proc.kill()
    assert proc.returncode == -signal.SIGTERM  # still dies of SIGTERM
    assert sorted(p.name for p in folder.iterdir()) == [name]
    assert target.read_bytes() == old


def test_a_handler_the_caller_installed_still_runs(tmp_path: Path) -> None:
    script = tmp_path / "mine.py"
    script.write_text(
        textwrap.dedent(
            """
            import os, signal, sys, time
            from pathlib import Path
            import cumuli as cu

            signal.signal(signal.SIGTERM, lambda *a: print("MINE", flush=True) or sys.exit(3))
            real = os.replace

            def slow(src, dst):
                os.kill(os.getpid(), signal.SIGTERM)
                time.sleep(5)
                real(src, dst)

            os.replace = slow
            cu.gaussian_cumulus(n=6, seed=3).save(Path(sys.argv[1]) / "c.npz")
            """
        )
    )
    done = subprocess.run(
        [sys.executable, str(script), str(tmp_path)], capture_output=True, text=True, timeout=60
    )
    assert done.returncode == 3 and "MINE" in done.stdout, done.stderr[-2000:]
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".c.npz")]


# --- mode and symlinks (item 8) -----------------------------------------------------------------
@pytest.mark.parametrize("name", ["a.png", "c.npz", "s.json"])
def test_the_replace_keeps_the_file_mode(tmp_path: Path, name: str) -> None:
    target = tmp_path / name
    _small(name, target)
    os.chmod(target, 0o600)
    _small(name, target)
    assert stat.S_IMODE(target.stat().st_mode) == 0o600
    os.chmod(target, 0o640)
    _small(name, target)
    assert stat.S_IMODE(target.stat().st_mode) == 0o640


@pytest.mark.parametrize("name", ["a.exr", "c.json", "s.json"])
def test_the_replace_writes_through_a_symlink(tmp_path: Path, name: str) -> None:
    real_dir = tmp_path / "real"
    real_dir.mkdir()
    real = real_dir / name
    _small(name, real)
    link = tmp_path / name
    link.symlink_to(real)
    before = real.read_bytes()
    if name.endswith(".exr"):
        cu.write_image(link, _noisy(5, 7, seed=9), exposure=1.0, tonemap="none")
    elif name.startswith("s"):
        cu.Scene(
            [_cloud().translated((1, 2, 3))], settings=cu.RenderSettings(lighting="paper")
        ).save(link)
    else:
        _cloud().translated((1, 2, 3)).save(link)
    assert link.is_symlink() and link.resolve() == real
    assert real.read_bytes() != before
    assert sorted(p.name for p in real_dir.iterdir()) == [name]
    dangling = tmp_path / ("d" + name)
    dangling.symlink_to(real_dir / ("new" + name))
    _small(name, dangling)
    assert dangling.is_symlink() and (real_dir / ("new" + name)).is_file()


# --- bounded memory (item 5) --------------------------------------------------------------------
def _blank_png(path: Path, width: int, height: int) -> None:
    """A valid all-zero RGBA8 PNG: a few hundred KB, whatever it declares."""

    def chunk(kind: bytes, data: bytes) -> bytes:
        crc = struct.pack(">I", zlib.crc32(kind + data))
        return struct.pack(">I", len(data)) + kind + data + crc

    packer = zlib.compressobj(9)
    row = b"\0" * (width * 4 + 1)
    data = b"".join(packer.compress(row) for _ in range(height)) + packer.flush()
    ihdr = struct.pack(">IIBBBBB", width, height, 8, 6, 0, 0, 0)
    path.write_bytes(
        b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", ihdr) + chunk(b"IDAT", data) + chunk(b"IEND", b"")
    )


def test_an_image_beyond_the_pixel_limit_is_refused_before_decoding(tmp_path: Path) -> None:
    path = tmp_path / "huge.png"
    _blank_png(path, 8192, 8193)  # 2²⁶ + 8192 pixels: 1 GiB as float32 RGBA
    assert path.stat().st_size < 1 << 20
    tracemalloc.start()
    try:
        with pytest.raises(ValueError, match=str(cio.MAX_PIXELS)) as err:
            cu.read_image(path)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert "nothing was decoded" in str(err.value)
    assert cio.MAX_PIXELS == 1 << 26 and peak < 1 << 20


def test_read_image_peaks_near_its_output(tmp_path: Path) -> None:
    img = np.zeros((2048, 2048, 4), np.float32)
    img[::7, ::5] = 0.5
    path = cu.write_image(tmp_path / "big.png", img, alpha="keep", exposure=1.0, tonemap="none")
    out_bytes = img.nbytes
    del img
    tracemalloc.start()
    try:
        back = cu.read_image(path)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert back.shape == (2048, 2048, 4) and back.dtype == np.float32
    assert peak < 1.4 * out_bytes, peak / out_bytes  # was ~8.5× (float64 intermediates)


@pytest.mark.parametrize("ext", [".png", ".exr"])
def test_write_image_allocates_little_beyond_its_input(tmp_path: Path, ext: str) -> None:
    img = _noisy(2048, 2048, seed=4)
    img[..., 3] = 0.5
    tracemalloc.start()
    try:
        cu.write_image(tmp_path / f"w{ext}", img, exposure=1.0, tonemap="none")
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert peak < 0.25 * img.nbytes, peak / img.nbytes  # PNG was ~4.2× (8× with the check)
    assert (img[..., 3] == 0.5).all()  # the caller's array is untouched


# --- what a saved render looks like (the first hour) --------------------------------------------
def test_a_saved_render_is_opaque_unless_alpha_is_kept(tmp_path: Path) -> None:
    scene = cu.Scene(
        [_cloud()], noise=cu.Noise(seed=2, size=16), settings=cu.RenderSettings(lighting="paper")
    )
    img = cu.render(scene, scene.default_camera(), 24, 16, backend="cpu")
    assert img[..., 3].min() < 0.01  # sky pixels: the render's alpha is the clouds' coverage
    for ext in (".png", ".exr"):
        seen = cu.read_image(
            cu.write_image(tmp_path / f"seen{ext}", img, exposure=1.0, tonemap="none")
        )
        np.testing.assert_array_equal(seen[..., 3], 1.0)
        kept = cu.read_image(
            cu.write_image(tmp_path / f"kept{ext}", img, alpha="keep", exposure=1.0, tonemap="none")
        )
        np.testing.assert_allclose(kept[..., 3], img[..., 3], atol=0.5 / 255)
    np.testing.assert_array_equal(cu.read_image(tmp_path / "kept.exr"), img)
    np.testing.assert_array_equal(cu.read_image(tmp_path / "seen.exr")[..., :3], img[..., :3])
    with pytest.raises(ValueError, match="alpha must be one of"):
        cu.write_image(tmp_path / "x.png", img, alpha="transparent", exposure=1.0, tonemap="none")
    with pytest.raises(ValueError, match="alpha"):
        cu.write_image(tmp_path / "x.png", img, alpha=True, exposure=1.0, tonemap="none")


def test_render_frames_saves_opaque_images_unless_alpha_is_kept(tmp_path: Path) -> None:
    scene = cu.Scene(
        [_cloud()], noise=cu.Noise(seed=2, size=16), settings=cu.RenderSettings(lighting="paper")
    )
    cams = cu.orbit((0, 2, 0), 40, 2)
    paths = cu.render_frames(scene, cams, tmp_path / "f", 16, 12, backend="cpu", progress=False)
    assert all((cu.read_image(p)[..., 3] == 1).all() for p in paths)
    kept = cu.render_frames(
        scene, cams, tmp_path / "k", 16, 12, backend="cpu", progress=False, alpha="keep"
    )
    assert min(float(cu.read_image(p)[..., 3].min()) for p in kept) < 0.01


def test_temporary_names_stay_within_name_max_for_any_length() -> None:
    for n in range(1, 256):
        prefix = _atomic._temp_prefix("x" * n, 255)
        assert len(prefix.encode()) + 8 <= 255
        prefix = _atomic._temp_prefix("é" * (n // 2 + 1), 255)
        prefix.encode("utf-8")  # no split character
        assert len(prefix.encode()) + 8 <= 255
