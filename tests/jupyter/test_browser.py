"""The viewer in a real browser: JupyterLab and Notebook 7 served on 127.0.0.1, a notebook with
a `cu.Viewer` run in headless Chromium (Debian's ``chromium`` + ``chromium-driver``, driven by
Selenium; nothing is downloaded), a mouse drag over the image and a slider moved; the camera, the
sun and the displayed frame must change. Screenshots are kept in ``tests/artifacts/browser/``
(one folder per front end)."""

from __future__ import annotations

import json
import os
import secrets
import shutil
import socket
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

pytestmark = pytest.mark.browser

ROOT = Path(__file__).resolve().parents[2]
ARTIFACTS = ROOT / "tests" / "artifacts" / "browser"
CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")
DRIVER = shutil.which("chromedriver")

NOTEBOOK_CELL = """\
import cumuli as cu
scene = cu.Scene([cu.gaussian_cumulus(n=10, seed=3)], noise=cu.Noise(seed=1, size=32),
                 sun=cu.Sun(direction=(0.6, 0.5, -0.4)))
viewer = cu.Viewer(scene, size=(320, 180), preview_size=(160, 90), backend="cpu")
viewer"""


def _needs() -> str | None:
    """Why the browser test cannot run here (None: it can)."""
    for module in ("selenium", "jupyterlab", "notebook", "anywidget"):
        try:
            __import__(module)
        except ImportError:
            return f"{module} is not installed (pip install -e '.[test]')"
    if CHROMIUM is None or DRIVER is None:
        return "Debian's chromium and chromium-driver are not installed (make test installs them)"
    return None


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def _jupyter_path() -> str:
    """The share/jupyter folders of every prefix on sys.path (lab extensions: anywidget's)."""
    found = []
    for entry in [sys.prefix, *sys.path]:
        p = Path(entry)
        for prefix in (p, *p.parents[:3]):
            share = prefix / "share" / "jupyter"
            if (share / "labextensions").is_dir() and str(share) not in found:
                found.append(str(share))
    return os.pathsep.join(found)


#: The two front ends the viewer must work in: (module to run, its app's config class, the path
#: that opens a notebook). Both are JupyterLab's components (Notebook 7 is built from them), so the
#: same commands run the cells.
FRONT_ENDS = {
    "jupyterlab": ("jupyterlab", "LabApp", "lab/tree"),
    "notebook7": ("notebook", "JupyterNotebookApp", "notebooks"),
}


@pytest.fixture(scope="module", params=sorted(FRONT_ENDS))
def lab(
    request: pytest.FixtureRequest, tmp_path_factory: pytest.TempPathFactory
) -> Iterator[tuple[str, Path]]:
    reason = _needs()
    if reason:
        pytest.skip(reason)
    import nbformat

    module, app, opens = FRONT_ENDS[request.param]
    root = tmp_path_factory.mktemp(request.param)
    nb = nbformat.v4.new_notebook()
    nb.cells = [nbformat.v4.new_code_cell(NOTEBOOK_CELL)]
    nb.metadata["kernelspec"] = {
        "name": "python3",
        "display_name": "Python 3",
        "language": "python",
    }
    nbformat.write(nb, root / "viewer.ipynb")
    port, token = _free_port(), secrets.token_hex(16)
    home = root / ".home"
    env = dict(
        os.environ,
        PYTHONPATH=os.pathsep.join(p for p in sys.path if p),
        JUPYTER_PATH=_jupyter_path(),
        JUPYTER_CONFIG_DIR=str(home / "config"),
        JUPYTER_RUNTIME_DIR=str(home / "runtime"),
        JUPYTERLAB_SETTINGS_DIR=str(home / "settings"),
        JUPYTERLAB_WORKSPACES_DIR=str(home / "workspaces"),
        IPYTHONDIR=str(home / "ipython"),
        CUMULI_PROGRESS="0",
    )
    cmd = [
        sys.executable, "-m", module, "--no-browser", "--ip=127.0.0.1", f"--port={port}",
        f"--IdentityProvider.token={token}", f"--ServerApp.root_dir={root}",
        "--ServerApp.port_retries=0", f"--{app}.expose_app_in_browser=True",
    ]  # fmt: skip
    if module == "jupyterlab":
        cmd.append("--LabApp.news_url=None")
    if hasattr(os, "geteuid") and os.geteuid() == 0:  # containers and CI run as root
        cmd.append("--allow-root")
    log = (root / "lab.log").open("w")
    server = subprocess.Popen(cmd, env=env, stdout=log, stderr=subprocess.STDOUT, cwd=root)
    try:
        deadline = time.monotonic() + 60
        while time.monotonic() < deadline:
            if server.poll() is not None:
                pytest.fail(f"{module} exited: " + (root / "lab.log").read_text()[-2000:])
            try:
                with socket.create_connection(("127.0.0.1", port), timeout=1):
                    break
            except OSError:
                time.sleep(0.3)
        else:
            pytest.fail(f"{module} did not listen within 60 s")
        yield f"http://127.0.0.1:{port}/{opens}/viewer.ipynb?token={token}", root
    finally:
        server.terminate()
        try:
            server.wait(timeout=15)
        except subprocess.TimeoutExpired:
            server.kill()
        log.close()


@pytest.fixture(scope="module")
def browser() -> Iterator[Any]:
    reason = _needs()
    if reason:
        pytest.skip(reason)
    from selenium import webdriver
    from selenium.webdriver.chrome.service import Service

    options = webdriver.ChromeOptions()
    options.binary_location = CHROMIUM
    for arg in ("--headless=new", "--no-sandbox", "--disable-dev-shm-usage", "--disable-gpu",
                "--window-size=1400,1100", "--disable-extensions"):  # fmt: skip
        options.add_argument(arg)
    driver = webdriver.Chrome(service=Service(executable_path=DRIVER), options=options)
    try:
        yield driver
    finally:
        driver.quit()


def _state(driver: Any, css: str = ".cumuli-viewer") -> dict[str, Any]:
    el = driver.find_element("css selector", css)
    return {
        "frames": int(el.get_attribute("data-frames") or 0),
        "kind": el.get_attribute("data-frame-kind"),
        "camera": json.loads(el.get_attribute("data-camera") or "{}"),
        "sun": json.loads(el.get_attribute("data-sun") or "[]"),
    }


def _wait(driver: Any, check: Any, timeout: float, what: str) -> Any:
    from selenium.webdriver.support.ui import WebDriverWait

    try:
        return WebDriverWait(driver, timeout, poll_frequency=0.2).until(check)
    except Exception:
        ARTIFACTS.mkdir(parents=True, exist_ok=True)
        driver.save_screenshot(str(ARTIFACTS / "failed.png"))
        raise AssertionError(f"timed out waiting for {what}") from None


KERNEL_READY = """const w = window.jupyterapp && window.jupyterapp.shell.currentWidget;
return !!(w && w.sessionContext && w.sessionContext.session
          && w.sessionContext.session.kernel);"""


def test_viewer_in_the_browser(lab: tuple[str, Path], browser: Any) -> None:
    """In each front end: drag over the frame, move the sun's slider."""
    from selenium.webdriver.common.action_chains import ActionChains

    url, _root = lab
    d = browser
    shots = ARTIFACTS / ("notebook7" if "/notebooks/" in url else "jupyterlab")
    shots.mkdir(parents=True, exist_ok=True)
    d.get(url)
    _wait(d, lambda d: d.execute_script(KERNEL_READY), 45, "the notebook's kernel")
    d.execute_script("window.jupyterapp.commands.execute('notebook:run-all-cells');")
    frame = ".cumuli-viewer img.cumuli-frame"
    _wait(d, lambda d: d.find_elements("css selector", frame + "[src]"), 60, "the first frame")
    img = d.find_element("css selector", frame)
    d.execute_script("arguments[0].scrollIntoView({block: 'center'});", img)
    _wait(d, lambda d: img.get_attribute("naturalWidth") not in (None, "0"), 20, "the image")
    before = _state(d)
    shot0 = img.screenshot_as_png
    d.save_screenshot(str(shots / "1_opened.png"))

    # Drag over the image: previews while moving, then the full frame.
    chain = ActionChains(d).move_to_element(img).click_and_hold()
    for _ in range(6):
        chain = chain.move_by_offset(12, 4).pause(0.1)
    chain.release().perform()

    def settled_after_drag(d: Any) -> bool:
        now = _state(d)
        return (
            now["kind"] == "full"
            and now["frames"] > before["frames"]
            and now["camera"] != before["camera"]
        )

    _wait(d, settled_after_drag, 30, "the full frame after the drag")
    dragged = _state(d)
    assert dragged["camera"]["azimuth"] != before["camera"]["azimuth"]
    assert dragged["camera"]["position"] != before["camera"]["position"]
    _wait(d, lambda d: img.screenshot_as_png != shot0, 10, "the displayed frame to change")
    shot1 = img.screenshot_as_png
    d.save_screenshot(str(shots / "2_dragged.png"))

    # The sun's azimuth slider, moved with the mouse.
    slider = d.find_element("css selector", ".cumuli-viewer input.cumuli-sun-azimuth")
    d.execute_script("arguments[0].scrollIntoView({block: 'center'});", slider)
    ActionChains(d).move_to_element(slider).click_and_hold().move_by_offset(60, 0).release(
    ).perform()  # fmt: skip

    def relit(d: Any) -> bool:
        now = _state(d)
        return now["sun"] != dragged["sun"] and now["frames"] > dragged["frames"]

    _wait(d, relit, 30, "the frame under the new sun")
    after = _state(d)
    assert after["sun"][0] != dragged["sun"][0] and after["camera"] == dragged["camera"]
    _wait(d, lambda d: img.screenshot_as_png != shot1, 10, "the displayed frame to change")
    d.save_screenshot(str(shots / "3_sun_moved.png"))
    states = {"before": before, "dragged": dragged, "after": after}
    (shots / "state.json").write_text(json.dumps(states, indent=1))
