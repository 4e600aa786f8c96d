"""Rendering lit density volumes (the database frames of Iwasaki et al. 2011).

:func:`render_volume` marches a ``(D, H, W)`` density volume lit by a ``(D, H, W, 4)`` light volume
(``τ_sun``, sky irradiance RGB, from :meth:`cumuli.VolumeLighting.light`) with emission–absorption:
``S = albedo·(sun·τ_sun·HG(g, cos θ) + E_sky/4π)``, ``colour += T·(1 − e^{−σ_t ρ h})·S``,
``T *= e^{−σ_t ρ h}`` in equal steps along the ray inside the volume's box; then
``rgb = colour + T·sky(d)``, ``alpha = 1 − T``. ``backend="cpu"`` runs the C++ reference,
``backend="gl"`` the fragment shader ``shaders/volume_march.frag.glsl`` over 3D textures; both give
``(H, W, 4)`` float32 images with row 0 on top.

The camera is a :class:`cumuli.Camera` (or any object with ``position``, ``target``, ``fov`` —
vertical, degrees — and optionally ``up``); the sky a :class:`cumuli.Sky` (or what
:func:`cumuli.sky.as_sky` accepts), whose radiance without the sun disc also lights the
volume through :class:`cumuli.VolumeLighting`. Background, sky model and phase function are the
render pass's own (``shaders/sky.glsl``, ``shaders/phase.glsl`` and their C++ twins).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import moderngl
import numpy as np

from cumuli import _core
from cumuli import _validate as check
from cumuli.camera import Camera
from cumuli.gl import GLContext, _resolve_context
from cumuli.model.volume import _box, _float_volumes
from cumuli.sky import Sun, as_sky, sky_args

BACKENDS = ("cpu", "gl")
#: Most steps a ray may take (the shader's loop bound).
MAX_STEPS = 1 << 16
#: Largest image edge.
MAX_IMAGE = 1 << 14


def camera_rays(camera: Any) -> dict[str, Any]:
    """Position, float32 forward/right/up basis and ``tan(fov/2)`` of a camera (a
    :class:`cumuli.Camera` uses its own :meth:`~cumuli.Camera.basis`)."""
    if isinstance(camera, Camera):
        f, r, u = camera.basis()
        return {
            "position": tuple(float(v) for v in camera.position),
            "forward": tuple(float(v) for v in f),
            "right": tuple(float(v) for v in r),
            "up": tuple(float(v) for v in u),
            "tan_half_fov": math.tan(math.radians(camera.fov) / 2),
        }
    for attr in ("position", "target", "fov"):
        if not hasattr(camera, attr):
            raise TypeError(f"camera must have position, target and fov, missing {attr!r}")
    pos = np.array(check.vec3(camera.position, "camera.position"), dtype=np.float32)
    tgt = np.array(check.vec3(camera.target, "camera.target"), dtype=np.float32)
    up = np.array(check.direction(getattr(camera, "up", (0, 1, 0)), "camera.up"), np.float32)
    fov = check.real(camera.fov, "camera.fov", 0.0, 180.0, lo_open=True, hi_open=True)
    view = tgt - pos
    norm = float(np.linalg.norm(view))
    if norm < 1e-6:
        raise ValueError("camera.target must differ from camera.position")
    f = (view / np.float32(norm)).astype(np.float32)
    r = np.cross(f, up).astype(np.float32)
    rn = float(np.linalg.norm(r))
    if rn < 1e-6:
        raise ValueError("camera.up must not be parallel to the view direction")
    r = (r / np.float32(rn)).astype(np.float32)
    u = np.cross(r, f).astype(np.float32)
    return {
        "position": tuple(float(v) for v in pos),
        "forward": tuple(float(v) for v in f),
        "right": tuple(float(v) for v in r),
        "up": tuple(float(v) for v in u),
        "tan_half_fov": math.tan(math.radians(fov) / 2),
    }


def _inputs(
    volume: Any, light: Any, box: Any, width: int, height: int, step: float | None
) -> tuple[np.ndarray, np.ndarray, tuple, tuple, int, int, float]:
    vol = _float_volumes(volume, "volume", 3)
    lig = _float_volumes(light, "light", 4)
    if lig.shape != (*vol.shape, 4):
        raise ValueError(f"light must have shape {(*vol.shape, 4)}, got {lig.shape}")
    if not isinstance(box, Sequence) or len(box) != 2:
        raise TypeError("box must be (box_min, box_max)")
    lo, hi = _box(box[0], box[1])
    width = check.integer(width, "width", 1, MAX_IMAGE)
    height = check.integer(height, "height", 1, MAX_IMAGE)
    diag = math.dist(lo, hi)
    if step is None:
        d, h, w = vol.shape
        step = 0.5 * min((hi[0] - lo[0]) / w, (hi[1] - lo[1]) / h, (hi[2] - lo[2]) / d)
    step = check.real(step, "step", 0.0, lo_open=True)
    if diag / step > MAX_STEPS:
        raise ValueError(f"step={step} needs more than {MAX_STEPS} steps across the box")
    return vol, lig, lo, hi, width, height, step


def render_volume(
    volume: Any,
    light: Any,
    box: tuple[Sequence[float], Sequence[float]],
    camera: Any,
    width: int,
    height: int,
    sun: Sun | None = None,
    sky: Any = None,
    backend: str = "cpu",
    *,
    sigma_t: float = 1.0,
    albedo: float = 1.0,
    g: float = 0.2,
    step: float | None = None,
    threads: int = 0,
    context: GLContext | None = None,
) -> np.ndarray:
    """Render a lit density volume: ``(height, width, 4)`` float32 linear RGBA, row 0 on top.

    ``volume`` ``(D, H, W)`` densities over ``box = (box_min, box_max)``; ``light`` ``(D, H, W, 4)``
    from :meth:`cumuli.VolumeLighting.light` (made with the same ``sigma_t``). ``step`` defaults
    to half the smallest voxel edge. ``g`` is the Henyey–Greenstein asymmetry of sun scattering.
    """
    if backend not in BACKENDS:
        raise ValueError(f"backend must be one of {BACKENDS}, got {backend!r}")
    sun = Sun() if sun is None else sun
    if not isinstance(sun, Sun):
        raise TypeError(f"sun must be a cumuli.Sun, got {type(sun).__name__}")
    vol, lig, lo, hi, width, height, step = _inputs(volume, light, box, width, height, step)
    cam = camera_rays(camera)
    sky = as_sky(sky)
    sigma_t = check.real(sigma_t, "sigma_t", 0.0)
    albedo = check.real(albedo, "albedo", 0.0, 1.0)
    g = check.real(g, "g", -1.0, 1.0, lo_open=True, hi_open=True)
    if backend == "cpu":
        return _core.render_volume_cpu(
            vol, lig, lo, hi, cam["position"], cam["forward"], cam["right"], cam["up"],
            cam["tan_half_fov"], width, height, sun.direction, sun.radiance, sky_args(sky),
            sigma_t, albedo, g, step, check.threads(threads),
        )  # fmt: skip
    with VolumeRenderer(context) as renderer:
        return renderer.render(
            vol, lig, (lo, hi), cam, width, height, sun, sky,
            sigma_t=sigma_t, albedo=albedo, g=g, step=step,
        )  # fmt: skip


class VolumeRenderer:
    """The GL volume marcher (``shaders/volume_march.frag.glsl``), reusable across frames.

    Compiles the program once on ``context`` (the default context when ``None``); each
    :meth:`render` uploads the density and light as 3D float textures and draws one triangle
    into a float framebuffer. Release with :meth:`release` or ``with``.
    """

    def __init__(self, context: GLContext | None = None) -> None:
        self.context = _resolve_context(context)
        ctx = self.context.ctx
        self.program: moderngl.Program | None = self.context.program(
            "volume/quad.vert.glsl", "volume/march.frag.glsl"
        )
        self.vao = ctx.vertex_array(self.program, [])
        self.gpu_time_ns: int | None = None

    def render(
        self,
        volume: Any,
        light: Any,
        box: tuple[Sequence[float], Sequence[float]],
        camera: Any,
        width: int,
        height: int,
        sun: Sun | None = None,
        sky: Any = None,
        *,
        sigma_t: float = 1.0,
        albedo: float = 1.0,
        g: float = 0.2,
        step: float | None = None,
    ) -> np.ndarray:
        """As :func:`render_volume` with ``backend="gl"``; ``camera`` may also be the dict of
        :func:`camera_rays`."""
        if self.program is None or self.context.closed:
            raise ValueError("this VolumeRenderer has been released")
        sun = Sun() if sun is None else sun
        if not isinstance(sun, Sun):
            raise TypeError(f"sun must be a cumuli.Sun, got {type(sun).__name__}")
        vol, lig, lo, hi, width, height, step = _inputs(volume, light, box, width, height, step)
        cam = camera if isinstance(camera, dict) else camera_rays(camera)
        sky = as_sky(sky)
        rad = math.radians(sky.sun_disc_radius)
        ctx = self.context.ctx
        d, h, w = vol.shape
        limit = int(self.context.info.get("GL_MAX_3D_TEXTURE_SIZE", 2048))
        if max(d, h, w) > limit:
            raise ValueError(
                f"volume edge {max(d, h, w)} exceeds this GL's 3D texture limit {limit}"
            )
        made: list[Any] = []
        try:
            dens = ctx.texture3d((w, h, d), 1, data=vol.tobytes(), dtype="f4")
            made.append(dens)
            ltex = ctx.texture3d((w, h, d), 4, data=lig.tobytes(), dtype="f4")
            made.append(ltex)
            for tex in (dens, ltex):
                tex.filter = (moderngl.NEAREST, moderngl.NEAREST)
            colour = ctx.texture((width, height), 4, dtype="f4")
            made.append(colour)
            fbo = ctx.framebuffer(color_attachments=[colour])
            made.append(fbo)
            prog = self.program
            values = {
                "u_density": 0,
                "u_light": 1,
                "u_box_min": lo,
                "u_box_max": hi,
                "u_cam_pos": cam["position"],
                "u_cam_forward": cam["forward"],
                "u_cam_right": cam["right"],
                "u_cam_up": cam["up"],
                "u_tan_half_fov": cam["tan_half_fov"],
                "u_resolution": (float(width), float(height)),
                "u_sun_dir": sun.direction,
                "u_sun_radiance": sun.radiance,
                "u_sky_zenith": sky.zenith,
                "u_sky_horizon": sky.horizon,
                "u_sky_ground": sky.ground,
                "u_sky_exponent": float(sky.exponent),
                "u_sun_disc": (math.cos(1.5 * rad), math.cos(rad)),
                "u_sun_disc_intensity": float(sky.sun_disc_intensity),
                "u_sigma_t": check.real(sigma_t, "sigma_t", 0.0),
                "u_albedo": check.real(albedo, "albedo", 0.0, 1.0),
                "u_g": check.real(g, "g", -1.0, 1.0, lo_open=True, hi_open=True),
                "u_step": step,
                "u_max_steps": MAX_STEPS,
            }
            for name, value in values.items():
                if name in prog:
                    prog[name].value = value
            dens.use(location=0)
            ltex.use(location=1)
            fbo.use()
            ctx.viewport = (0, 0, width, height)
            query = self.context.timer_query()
            with query:
                self.vao.render(moderngl.TRIANGLES, vertices=3)
            ctx.finish()
            self.gpu_time_ns = int(query.elapsed)
            img = np.frombuffer(fbo.read(components=4, dtype="f4"), dtype=np.float32)
            return np.ascontiguousarray(img.reshape(height, width, 4)[::-1])
        finally:
            for obj in made:
                obj.release()

    def release(self) -> None:
        """Release the program (idempotent)."""
        if self.program is not None and not self.context.closed:
            self.vao.release()
            self.program.release()
        self.program = None

    def __enter__(self) -> VolumeRenderer:
        return self

    def __exit__(self, *exc: object) -> None:
        self.release()
