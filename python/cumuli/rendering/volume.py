"""The volume marcher: lit density volumes (the database frames of Iwasaki et al. 2011).

:class:`VolumeRenderer` (GL) and :func:`render_volume_cpu` (its C++ twin) march a ``(D, H, W)``
density volume lit by a ``(D, H, W, 4)`` light volume
(``τ_sun``, sky irradiance RGB, from :meth:`cumuli.VolumeLighting.light`) with emission–absorption:
``S = albedo·(sun·τ_sun·HG(g, cos θ) + E_sky/4π)``, ``colour += T·(1 − e^{−σ_t ρ h})·S``,
``T *= e^{−σ_t ρ h}`` in equal steps along the ray inside the volume's box; then
``rgb = colour + T·sky(d)``, ``alpha = 1 − T`` (or, for the compositor, the premultiplied layer
``(colour, 1 − T)``). The GL side is the fragment shader ``shaders/volume/march.frag.glsl`` over
3D textures; both give ``(H, W, 4)`` float32 images with row 0 on top. :class:`VolumeGL` and
:func:`draw_volume_cpu` are the drawers of `VolumeCloud` (kind ``"volume"``);
:func:`cumuli.render_volume` renders one volume through the compositor.

The camera is a :class:`cumuli.Camera` (or any object with ``position``, ``target``, ``fov`` —
vertical, degrees — and optionally ``up``); the sky a :class:`cumuli.Sky` (or what
:func:`cumuli.sky.as_sky` accepts), whose radiance without the sun disc also lights the
volume through :class:`cumuli.VolumeLighting`. Background, sky model and phase function are the
render pass's own (``shaders/common/sky.glsl``, ``shaders/common/phase.glsl`` and their C++ twins).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import moderngl
import numpy as np

from cumuli import _core
from cumuli._util import validate as check
from cumuli.camera import Camera
from cumuli.gl.context import GLContext, _resolve_context
from cumuli.light.physical import PhysicalLight
from cumuli.light.prepare import LitScene
from cumuli.model.solid import Solid, as_solids, solid_arrays
from cumuli.model.volume import MAX_SIGMA_T, _box, _float_volumes
from cumuli.rendering.marcher_cpu import physical_core_tuple
from cumuli.rendering.params import physical_params, sky_params, sky_uniforms, sun_params
from cumuli.rendering.physical_gl import bind_physical
from cumuli.rendering.solids import set_solid_uniforms
from cumuli.rendering.volume_detail import VolumeDetail, volume_detail
from cumuli.sky import Sun, as_sky

#: Most steps a ray may take (the shader's loop bound).
MAX_STEPS = 1 << 16
#: Largest image edge.
MAX_IMAGE = 1 << 14
#: The texture unit of the detail noise's lattice (0, 1: density and light; 2, 3: the physical
#: light's atlases).
NOISE_UNIT = 4
#: Largest image in pixels (the compositor's limit: 2²⁶ RGBA32F pixels = 1 GiB).
MAX_PIXELS = 1 << 26


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
    if width * height > MAX_PIXELS:
        raise ValueError(
            f"image of {width}x{height} pixels is larger than the limit of {MAX_PIXELS} pixels"
        )
    diag = math.dist(lo, hi)
    if step is None:
        d, h, w = vol.shape
        step = 0.5 * min((hi[0] - lo[0]) / w, (hi[1] - lo[1]) / h, (hi[2] - lo[2]) / d)
    step = check.real(step, "step", 0.0, lo_open=True)
    if diag / step > MAX_STEPS:
        raise ValueError(f"step={step} needs more than {MAX_STEPS} steps across the box")
    return vol, lig, lo, hi, width, height, step


class VolumeRenderer:
    """The GL volume marcher (``shaders/volume/march.frag.glsl``), reusable across frames.

    Compiles the program once on ``context`` (the default context when ``None``); each
    :meth:`render` uploads the density and light as 3D float textures and draws one triangle
    into a float framebuffer. Release with :meth:`release` or ``with``.
    """

    def __init__(self, context: GLContext | None = None) -> None:
        self.context = _resolve_context(context)
        ctx = self.context.ctx
        with self.context.activate():
            self.program: moderngl.Program | None = self.context.program(
                "volume/quad.vert.glsl", "volume/march.frag.glsl"
            )
            self.vao = ctx.vertex_array(self.program, [])
            self.context.timer_query()
        self.gpu_time_ns: int | None = None
        self._physical: tuple[Any, Any] | None = None  # the PHYSICAL variant, made on first use
        self._noise: tuple[tuple[int, int], Any] | None = None  # the detail noise's texture

    def _physical_program(self) -> tuple[Any, Any]:
        if self._physical is None:
            program = self.context.program(
                "volume/quad.vert.glsl", "volume/march.frag.glsl", defines={"PHYSICAL": 1}
            )
            self._physical = (program, self.context.ctx.vertex_array(program, []))
        return self._physical

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
        with_sky: bool = True,
        solids: Sequence[Solid] = (),
        physical: Any = None,
        detail: VolumeDetail | None = None,
    ) -> np.ndarray:
        """As :func:`cumuli.render_volume` with ``backend="gl"``; ``camera`` may also be the dict
        of :func:`camera_rays`. ``with_sky=False`` gives the premultiplied layer
        ``(colour, 1 − T)`` the compositor combines; each ray stops at the nearest of the opaque
        ``solids``. ``physical`` ``(settings, PhysicalLight)`` selects the physical mode
        (``light`` is then not read), where ``detail`` (a
        :class:`~cumuli.rendering.volume_detail.VolumeDetail`) reads the density as a sharp
        volume (None: trilinear, not eroded)."""
        if self.program is None or self.context.closed:
            raise ValueError("this VolumeRenderer has been released")
        with self.context.activate("this VolumeRenderer's GL context"):
            return self._render(
                volume, light, box, camera, width, height, sun, sky, sigma_t, albedo, g, step,
                with_sky, solids, physical, detail,
            )  # fmt: skip

    def _noise_texture(self, noise: Any) -> Any:
        """The detail noise's lattice as a LINEAR / REPEAT R32F 3D texture (kept across
        renders of the same lattice)."""
        key = noise.identity
        cached = self._noise
        if cached is not None and cached[0] == key:
            return cached[1]
        if cached is not None:
            cached[1].release()
        n = noise.size
        tex = self.context.ctx.texture3d((n, n, n), 1, noise.lattice.tobytes(), dtype="f4")
        tex.filter = (moderngl.LINEAR, moderngl.LINEAR)
        tex.repeat_x = tex.repeat_y = tex.repeat_z = True
        self._noise = (key, tex)
        return tex

    def _render(
        self, volume: Any, light: Any, box: Any, camera: Any, width: int, height: int, sun: Any,
        sky: Any, sigma_t: float, albedo: float, g: float, step: float | None, with_sky: bool,
        solids: Sequence[Solid], physical: Any, detail: VolumeDetail | None,
    ) -> np.ndarray:  # fmt: skip
        sun = Sun() if sun is None else sun
        if not isinstance(sun, Sun):
            raise TypeError(f"sun must be a cumuli.Sun, got {type(sun).__name__}")
        vol, lig, lo, hi, width, height, step = _inputs(volume, light, box, width, height, step)
        cam = camera if isinstance(camera, dict) else camera_rays(camera)
        sky = as_sky(sky)
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
            prog, vao = self.program, self.vao
            if physical is not None:
                settings, plight = physical
                prog, vao = self._physical_program()

                def set_(name: str, value: Any, prog: Any = prog) -> None:
                    if name in prog:
                        prog[name].value = value

                made += bind_physical(ctx, set_, settings, [plight], limit)
                set_("u_exact_light", bool(settings.exact_noise))
                _set_detail(set_, detail)
                if detail is not None and detail.strength > 0.0:
                    self._noise_texture(detail.noise).use(location=NOISE_UNIT)
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
                **sky_uniforms(sky, sun),
                "u_sigma_t": check.real(sigma_t, "sigma_t", 0.0, MAX_SIGMA_T),
                "u_albedo": check.real(albedo, "albedo", 0.0, 1.0),
                "u_g": check.real(g, "g", -1.0, 1.0, lo_open=True, hi_open=True),
                "u_step": step,
                "u_max_steps": MAX_STEPS,
                "u_with_sky": bool(with_sky),
            }
            for name, value in values.items():
                if name in prog:
                    prog[name].value = value
            set_solid_uniforms(prog, as_solids(solids))
            dens.use(location=0)
            ltex.use(location=1)
            fbo.use()
            ctx.viewport = (0, 0, width, height)
            query = self.context.timer_query()
            with query:
                vao.render(moderngl.TRIANGLES, vertices=3)
            ctx.finish()
            self.gpu_time_ns = int(query.elapsed)
            img = np.frombuffer(fbo.read(components=4, dtype="f4"), dtype=np.float32)
            return np.ascontiguousarray(img.reshape(height, width, 4)[::-1])
        finally:
            for obj in made:
                obj.release()

    def release(self) -> None:
        """Release the programs (idempotent)."""
        if self.program is not None and not self.context.closed:
            with self.context.activate("this VolumeRenderer's GL context"):
                self.vao.release()
                self.program.release()
                if self._physical is not None:
                    self._physical[1].release()
                    self._physical[0].release()
                if self._noise is not None:
                    self._noise[1].release()
        self.program = None
        self._physical = None
        self._noise = None

    def __enter__(self) -> VolumeRenderer:
        return self

    def __exit__(self, *exc: object) -> None:
        self.release()


def render_volume_cpu(
    volume: np.ndarray,
    light: np.ndarray,
    box: tuple[tuple[float, float, float], tuple[float, float, float]],
    camera: Any,
    width: int,
    height: int,
    sun: Sun,
    sky: Any,
    *,
    sigma_t: float,
    albedo: float,
    g: float,
    step: float | None,
    threads: int = 0,
    with_sky: bool = True,
    solids: Sequence[Solid] = (),
    physical: Any = None,
    detail: VolumeDetail | None = None,
) -> np.ndarray:
    """The C++ twin of :meth:`VolumeRenderer.render` (``_core.render_volume_cpu``)."""
    solids = as_solids(solids)
    spheres = solid_arrays(solids)[0] if solids else None
    vol, lig, lo, hi, width, height, step = _inputs(volume, light, box, width, height, step)
    cam = camera if isinstance(camera, dict) else camera_rays(camera)
    rays = _core.VolumeCamera()
    rays.position, rays.forward, rays.right, rays.up = (
        cam["position"], cam["forward"], cam["right"], cam["up"],
    )  # fmt: skip
    rays.tan_half_fov = cam["tan_half_fov"]
    p = _core.VolumeRenderParams()
    p.width, p.height, p.sun, p.sky = width, height, sun_params(sun), sky_params(as_sky(sky))
    p.sigma_t = check.real(sigma_t, "sigma_t", 0.0, MAX_SIGMA_T)
    p.albedo = check.real(albedo, "albedo", 0.0, 1.0)
    p.g = check.real(g, "g", -1.0, 1.0, lo_open=True, hi_open=True)
    p.step, p.with_sky = step, bool(with_sky)
    plight = None
    if physical is not None:
        settings, plight = physical
        p.physical, p.phys = True, physical_params(settings, plight.octaves)
        plight = physical_core_tuple(plight)
    noise = None
    if physical is not None and detail is not None:
        p.cubic, p.detail, p.detail_inv_max = detail.cubic, detail.strength, detail.inv_max
        p.detail_fbm = _core.FbmParams(*detail.fbm)
        noise = detail.noise._core if detail.strength > 0.0 else None
    return _core.render_volume_cpu(
        vol, lig, lo, hi, rays, p, check.threads(threads), spheres, plight, noise
    )  # fmt: skip


def _volume_args(lit: LitScene, k: int) -> tuple[Any, ...]:
    volume = lit.scene.clouds[k]
    light = lit.lights[k]
    if isinstance(light, PhysicalLight):  # the paper mode's light volume is not read
        light = np.zeros((*volume.shape, 4), np.float32)
    return volume.density, light, volume.box


def _physical(lit: LitScene, k: int) -> Any:
    light = lit.lights[k]
    return (lit.scene.settings, light) if isinstance(light, PhysicalLight) else None


def _medium(lit: LitScene, k: int) -> dict[str, Any]:
    """The marcher's keywords for volume ``k`` of ``lit``: its medium and sharp-volume detail."""
    v = lit.scene.clouds[k]
    detail = volume_detail(v, lit.scene) if _physical(lit, k) is not None else None
    return {
        "sigma_t": v.extinction_per_density(lit.scene.settings), "albedo": v.albedo, "g": v.g,
        "step": v.step, "solids": lit.scene.solids, "physical": _physical(lit, k),
        "detail": detail,
    }  # fmt: skip


def _set_detail(set_: Any, detail: VolumeDetail | None) -> None:
    """The physical variant's sharp-volume uniforms (trilinear, no erosion for None)."""
    set_("u_cubic", bool(detail is not None and detail.cubic))
    strength = 0.0 if detail is None else detail.strength
    set_("u_detail", strength)
    set_("u_detail_inv_max", 1.0 if detail is None else detail.inv_max)
    if detail is not None and strength > 0.0:
        octaves, gain, lacunarity, frequency = detail.fbm
        set_("u_lattice", NOISE_UNIT)
        # Version 2's exact lookup hashes its corners (shaders/common/noise.glsl).
        set_("u_noise_hash", detail.noise.version == 2)
        set_("u_noise_key", detail.noise.key)
        set_("u_octaves", octaves)
        set_("u_gain", gain)
        set_("u_lacunarity", lacunarity)
        set_("u_frequency", frequency)


class VolumeGL:
    """Draws `VolumeCloud` drawables of a lit scene with :class:`VolumeRenderer` (a layer drawer,
    see :mod:`cumuli.rendering.kinds`); one volume per draw."""

    groups = False
    clips_solids = True

    def __init__(self, gl: GLContext, tiles: Any = None) -> None:
        self.renderer = VolumeRenderer(gl)

    @property
    def last_gpu_ns(self) -> int | None:
        """GL timer-query time of the last draw (None when the driver could not time it)."""
        ns = self.renderer.gpu_time_ns
        return ns if ns is not None and 0 <= ns < 0xFFFFFFFF else None

    @staticmethod
    def check(scene: Any, indices: Sequence[int]) -> None:
        """Nothing to check before the light pass."""

    def draw(
        self,
        lit: LitScene,
        indices: Sequence[int],
        camera: Camera,
        width: int,
        height: int,
        with_sky: bool,
    ) -> np.ndarray:
        (k,) = indices
        return self.renderer.render(
            *_volume_args(lit, k), camera, width, height, lit.scene.sun, lit.scene.sky,
            with_sky=with_sky, **_medium(lit, k),
        )  # fmt: skip

    def release(self) -> None:
        self.renderer.release()


def draw_volume_cpu(
    lit: LitScene,
    indices: Sequence[int],
    camera: Camera,
    width: int,
    height: int,
    with_sky: bool,
    threads: int = 0,
) -> np.ndarray:
    """The CPU twin of :meth:`VolumeGL.draw`."""
    (k,) = indices
    return render_volume_cpu(
        *_volume_args(lit, k), camera, width, height, lit.scene.sun, lit.scene.sky,
        threads=threads, with_sky=with_sky, **_medium(lit, k),
    )  # fmt: skip
