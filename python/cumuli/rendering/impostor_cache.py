"""Dynamically generated impostors for every kind of cloud (Harris 2002 §3, §3.1, §3.1.1, §4).

An :class:`ImpostorCache` lives across frames. Each frame, for every drawable of the scene:

0. **Units**: one impostor per drawable, or per *part* of a drawable that has parts (the
   ``impostor_parts()`` protocol of :mod:`cumuli.model.parts`: every instance of a
   `BillboardField` — a sky of a thousand clouds drifting with the wind keeps each cloud's
   image); see :mod:`cumuli.rendering.impostor_units`.
1. **Cull** it when the sphere its display can cover lies outside the view frustum (its bounding
   sphere, or the quad of a kept impostor): culling never changes the image. A drawable culled
   for more than ``release_after`` frames drops its impostor (GL: the texture returns to the
   pool), as SkyWorks does.
2. **Update test** (§7.3): ``"missing"``, ``"cloud"`` (its content changed — a pure translation
   does not count: a translated `ParticleCloud` or `BillboardCloud`, a field instance moved by
   the wind, keeps its impostor, displayed moved), ``"light"`` (its light, the sun/lights'
   colours or the settings changed), then
   :func:`~cumuli.rendering.impostors.needs_update` (``"screen"``, ``"backwards"``,
   ``"translation"`` at ``tolerance`` degrees, ``"resolution"``).
3. **Generate** when needed: the drawable's own layer, drawn **alone** by its kind's drawer
   through the tight impostor camera (``res × res``) or, when the eye is inside or near it, through
   the view camera at ``⌈W/f⌉ × ⌈H/f⌉`` (a screen impostor, regenerated every frame). This is the
   same call for marched 2018 clouds, volumes, particles and any kind registered later.
4. **Solids inside** (§7.5): a cloud whose bounding sphere holds ``m`` solids' centres is split
   into ``m + 1`` impostor layers at the solids' sort keys when its kind can split (particles,
   billboard clouds and field instances),
   displayed and combined with the solids back to front (``composite_split``); a marched kind is
   instead drawn stopping every ray at the solids (exact) — both regenerate every frame.
5. **Display**: the impostors of one draw call (a group of one kind, e.g. all particle clouds)
   back to front by distance as quads into one premultiplied layer (GL hardware bilinear, or
   ``exact`` texelFetch blends; the CPU twin ``_core.display_impostors``); the layers go through
   the compositor like any other.

``cache.stats`` and ``cache.history`` count updates per frame by reason, texels held, splats
drawn, culled clouds and impostors.
"""

from __future__ import annotations

import math
from collections import Counter
from collections.abc import Sequence
from typing import Any

import numpy as np

from cumuli import _core, registry
from cumuli.camera import Camera
from cumuli.gl.sprites import camera_dict
from cumuli.light.prepare import LitScene
from cumuli.rendering.impostor_units import (
    Unit,
    drawable_sphere,
    same_content,
    same_light,
    unit_content,
    units,
)
from cumuli.rendering.impostors import ImpostorState, view_reason
from cumuli.rendering.solids import composite_split, solids_inside

__all__ = ["Impostor", "ImpostorCache", "drawable_sphere", "same_content"]


class Impostor:
    """One cached impostor: its image (premultiplied, row 0 on top) on a plane, and what it was
    made from. ``plane`` is the display quad now: centre (moved with the cloud), forward, right,
    up, half width, half height. ``index`` is the drawable's index in the scene, ``part`` the
    part's index in it (None for a whole drawable)."""

    def __init__(self, kind: str, index: int, part: int | None = None) -> None:
        self.kind = kind
        self.index = index
        self.part = part
        self.signature: Any = None
        self.drawable: Any = None
        self.light: Any = None
        self.light_of: Any = None  # the drawable's light this impostor's light matches
        self.state: ImpostorState | None = None
        self.image = np.zeros((1, 1, 4), np.float32)
        self.plane0 = np.zeros(14)
        self.anchor0 = np.zeros(3)
        self.offset = np.zeros(3)
        self.clamp = False
        self.version = 0
        self.culled = 0
        self.clipped = False  # drawn stopping at solids (valid for its eye only)
        self.gl_texture: Any = None

    @property
    def plane(self) -> np.ndarray:
        if not self.offset.any():
            return self.plane0
        p = self.plane0.copy()
        p[0:3] += self.offset
        return p

    @property
    def texels(self) -> int:
        return int(self.image.shape[0] * self.image.shape[1])

    def reach(self) -> float:
        """Radius around the quad's centre that holds everything its display can cover."""
        return math.hypot(self.plane0[12], self.plane0[13])


class ImpostorCache:
    """Impostors of a scene's drawables, kept across frames (see the module docstring).

    Pass it to :meth:`cumuli.Renderer.render` / :func:`cumuli.render` (``impostors=cache``) or
    :func:`cumuli.render_cpu` frame after frame; settings come from ``scene.impostor_settings``.
    A cache used with a GL renderer holds textures of that renderer: :meth:`release` returns
    them (the renderer's close does too).
    """

    def __init__(self, renderer: Any = None) -> None:
        # A GL renderer (cumuli.Renderer: it renders and owns textures) or None.
        if renderer is not None and not (
            callable(getattr(renderer, "render", None)) and hasattr(renderer, "close")
        ):
            raise TypeError(
                f"renderer must be a cumuli.Renderer or None, got {type(renderer).__name__}"
            )
        self.renderer = renderer
        self._entries: dict[Any, Impostor] = {}
        self._token: Any = None
        self._painter: Any = None
        #: One dict per frame: updates by reason, impostors, screen, split, culled, texels,
        #: splats, released.
        self.history: list[dict[str, Any]] = []

    # --- statistics ----------------------------------------------------------------------------
    @property
    def stats(self) -> dict[str, Any]:
        """Totals over the frames so far and the last frame: ``frames``, ``updates`` (by
        reason), ``updates_per_frame`` (mean), ``texels`` (held now), ``splats`` (drawn, total),
        ``culled`` (last frame), ``impostors`` (held now), ``last`` (the last frame's record)."""
        totals: Counter[str] = Counter()
        for h in self.history:
            totals.update(h["updates"])
        n = len(self.history)
        return {
            "frames": n,
            "updates": dict(totals),
            "updates_per_frame": sum(totals.values()) / n if n else 0.0,
            "texels": sum(e.texels for e in self._entries.values()),
            "splats": sum(h["splats"] for h in self.history),
            "culled": self.history[-1]["culled"] if n else 0,
            "impostors": len(self._entries),
            "last": self.history[-1] if n else None,
        }

    @property
    def entries(self) -> dict[Any, Impostor]:
        """The impostors held: by drawable index, or ``(index, part key)`` for a part (a
        field's instance: ``(index, instance id)``)."""
        return dict(self._entries)

    def clear(self) -> None:
        """Drop every impostor (the next frame regenerates them)."""
        for e in self._entries.values():
            if self._painter is not None:
                self._painter.forget(e)
        self._entries.clear()
        self._token = None

    release = clear

    def detach(self) -> None:
        """Forget the GL textures of a closed renderer (the images stay and are uploaded again
        by the next GL renderer)."""
        for e in self._entries.values():
            e.gl_texture = None
        self._painter = None
        self.renderer = None

    # --- one frame -----------------------------------------------------------------------------
    def layers(
        self,
        lit: LitScene,
        calls: Sequence[tuple[str, list[int]]],
        camera: Camera,
        width: int,
        height: int,
        painter: Any,
    ) -> tuple[list[np.ndarray], list[np.ndarray]]:
        """The frame's layers and their boxes ``(2, 3)``, one per draw call that shows anything."""
        if self._painter is not None and self._painter.backend != painter.backend:
            self.clear()  # GL textures belong to the other backend's renderer
        self._painter = painter
        scene = lit.scene
        s = scene.impostor_settings
        token = (
            scene.sun, scene.lights, scene.settings, scene.sprite_settings, scene.noise.identity,
            s,
        )  # fmt: skip
        stale_token = token != self._token
        self._token = token
        plain = LitScene(scene.replace(solids=()), lit.lights) if scene.solids else lit
        record: dict[str, Any] = {
            "updates": Counter(), "impostors": 0, "screen": 0, "split": 0, "culled": 0,
            "released": 0,
        }  # fmt: skip
        splats0 = painter.splats()
        cam = camera_dict(camera, width, height, s.near)
        eye = tuple(float(v) for v in camera.position)
        seen: set[Any] = set()
        layers: list[np.ndarray] = []
        boxes: list[np.ndarray] = []
        for _kind, indices in calls:
            quads: list[tuple[float, int, Impostor]] = []
            lo_hi: list[np.ndarray] = []
            for k in indices:
                queued = False
                for unit in units(lit, k):
                    seen.add(unit.key)
                    queued |= self._unit(
                        lit, plain, unit, stale_token, camera, width, height, s, painter, record,
                        eye, cam, quads, layers, boxes,
                    )  # fmt: skip
                if queued:
                    lo_hi.append(scene.clouds[k].layer_box())
            if quads:
                ordered = [q for _, _, q in sorted(quads, key=lambda t: (t[0], t[1]))]
                layers.append(painter.display(ordered, camera, width, height, s.exact))
                stacked = np.asarray(lo_hi, np.float32)
                boxes.append(np.stack([stacked[:, 0].min(axis=0), stacked[:, 1].max(axis=0)]))
        for key in [key for key in self._entries if key not in seen]:
            painter.forget(self._entries.pop(key))
        record["texels"] = sum(e.texels for e in self._entries.values())
        record["splats"] = painter.splats() - splats0
        record["updates"] = dict(record["updates"])
        self.history.append(record)
        return layers, boxes

    def _unit(
        self, lit: LitScene, plain: LitScene, unit: Unit, stale_token: bool, camera: Camera,
        width: int, height: int, s: Any, painter: Any, record: dict[str, Any],
        eye: tuple[float, float, float], cam: dict[str, Any], quads: list[Any],
        layers: list[np.ndarray], boxes: list[np.ndarray],
    ) -> bool:  # fmt: skip
        """One unit's impostor this frame: split (its own layer, appended to ``layers``),
        culled, or kept/regenerated and queued in ``quads``. True when it joins the quads."""
        scene = lit.scene
        kind, centre, radius = unit.kind, unit.centre, unit.radius
        inside = solids_inside(scene.solids, centre, radius) if scene.solids else []
        if inside and s.split and painter.can_split(kind):
            sub, j = unit.lit(lit)
            layers.append(self._split(sub, j, unit, inside, camera, width, height, painter))
            record["updates"]["split"] += 1
            record["split"] += 1
            boxes.append(self._box(sub.scene.clouds[j], [scene.solids[i] for i in inside]))
            return False
        entry = self._entries.get(unit.key)
        reason, offset = self._reason(entry, unit, lit, stale_token, camera, width, height, s)
        clip_now = bool(inside) and painter.clips_solids(kind)
        if clip_now:
            reason = "clip"  # drawn stopping at the solids: valid for this eye only
        elif reason is None and entry is not None and entry.clipped:
            reason = "clip"  # the solid left: the clipped image must go
        # Cull with what the display can cover: a fresh impostor stays in the sphere.
        if reason is None and entry is not None:
            reach_c, reach_r = entry.plane[0:3], max(entry.reach(), radius)
        else:
            reach_c, reach_r = centre, radius
        if s.cull and _core.sphere_outside_frustum(reach_c, reach_r, cam):
            record["culled"] += 1
            if entry is not None:
                entry.culled += 1
                if entry.culled > s.release_after:
                    painter.forget(entry)
                    del self._entries[unit.key]
                    record["released"] += 1
            return False
        if reason is not None:
            entry = self._generate(entry, unit, lit if clip_now else plain, camera, width, height,
                                   s, painter)  # fmt: skip
            record["updates"][reason] += 1
        else:
            assert entry is not None
            entry.offset = offset
        entry.culled = 0
        record["impostors"] += 1
        record["screen"] += int(entry.clamp)
        # Back to front by the distance to the point the direct drawer sorts by.
        quads.append((-math.dist(unit.order, eye), len(quads), entry))
        return True

    @staticmethod
    def _box(drawable: Any, solids: Sequence[Any]) -> np.ndarray:
        """The compositor's box of an impostor layer: the drawable's own ``layer_box()`` — the
        order is then the direct rendering's — grown by the solids drawn with it. (An impostor
        seen from a moved eye may show content up to α_trans outside it, which the compositor
        drops: at the tolerance that is under a pixel, where splats and marched edges fade.)"""
        lo, hi = (np.asarray(v, np.float64) for v in drawable.layer_box())
        for sol in solids:
            slo, shi = sol.bounds()
            lo, hi = np.minimum(lo, slo), np.maximum(hi, shi)
        return np.stack([lo, hi]).astype(np.float32)

    def _reason(
        self, entry: Impostor | None, unit: Unit, lit: LitScene, stale_token: bool,
        camera: Camera, width: int, height: int, s: Any,
    ) -> tuple[str | None, np.ndarray]:  # fmt: skip
        zero = np.zeros(3)
        if entry is None or entry.state is None:
            return "missing", zero
        if entry.kind != unit.kind:
            return "cloud", zero
        same, offset = unit_content(entry, unit, lit)
        if not same:
            return "cloud", zero
        if stale_token:
            return "light", zero
        # A part's light is cut from its drawable's: the same drawable light object (a LitScene
        # drawn again) needs no comparison.
        whole = lit.lights[unit.k]
        if unit.part is None or entry.light_of is not whole:
            if not same_light(entry.light, unit.light(lit)):
                return "light", zero
            entry.light_of = whole
        eye = tuple(float(v) for v in np.subtract(camera.position, offset))
        return view_reason(entry.state, eye, camera.fov, width, height, s), offset

    @staticmethod
    def _view(state: ImpostorState, camera: Camera, centre: np.ndarray) -> tuple[Any, ...]:
        """``(camera, (w, h), plane)`` an impostor of ``state`` is drawn with and shown on: the
        view camera and the view plane at distance 1 for a screen impostor, else the tight
        camera and the plane through the centre ⟂ its forward, half size d₀·tan(fov/2)."""
        if state.screen:
            w, h = state.size
            f, r, u = (v.astype(np.float64) for v in camera.basis())
            th = math.tan(math.radians(camera.fov) / 2)
            plane_c = np.asarray(camera.position, np.float64) + f
            return camera, (w, h), np.concatenate([plane_c, f, r, u, (th * w / h, th)])
        assert state.view is not None
        cam = state.view.camera()
        f, r, u = (v.astype(np.float64) for v in cam.basis())
        d0 = float(np.dot(np.asarray(centre) - np.asarray(cam.position, np.float64), f))
        hs = d0 * math.tan(math.radians(cam.fov) / 2)
        plane_c = np.asarray(cam.position, np.float64) + d0 * f
        return cam, state.size, np.concatenate([plane_c, f, r, u, (hs, hs)])

    def _generate(
        self, entry: Impostor | None, unit: Unit, lit: LitScene, camera: Camera, width: int,
        height: int, s: Any, painter: Any,
    ) -> Impostor:  # fmt: skip
        entry = entry if entry is not None else Impostor(unit.kind, unit.k, unit.part)
        centre, radius = unit.centre, unit.radius
        state = ImpostorState.generate(tuple(centre), radius, camera, width, height, s)
        cam, (w, h), plane = self._view(state, camera, centre)
        sub, j = unit.lit(lit)
        entry.image = np.ascontiguousarray(painter.layer(sub, unit.kind, [j], cam, w, h, False))
        entry.plane0 = plane
        entry.kind, entry.index, entry.part = unit.kind, unit.k, unit.part
        entry.drawable, entry.light, entry.state = sub.scene.clouds[j], sub.lights[j], state
        entry.light_of = lit.lights[unit.k]
        entry.signature = unit.signature
        anchor = centre if unit.anchor is None else unit.anchor
        entry.anchor0, entry.offset = np.asarray(anchor, np.float64), np.zeros(3)
        entry.clamp = state.screen
        entry.clipped = bool(lit.scene.solids)
        entry.version += 1
        self._entries[unit.key] = entry
        return entry

    def _split(
        self, lit: LitScene, k: int, unit: Unit, inside: list[int], camera: Camera, width: int,
        height: int, painter: Any,
    ) -> np.ndarray:  # fmt: skip
        """[H] §3.1.1: drawable ``k`` of ``lit`` (the unit, alone when it is a part) cut at its
        solids' sort keys into m + 1 impostor layers through the impostor camera (tight, or the
        screen's), displayed and combined with the solids back to front (the solids
        depth-tested among themselves)."""
        scene = lit.scene
        centre, radius = unit.centre, unit.radius
        s = scene.impostor_settings
        state = ImpostorState.generate(tuple(centre), radius, camera, width, height, s)
        cam, (w, h), plane = self._view(state, camera, centre)
        # Keys as the impostor camera sorts the kind's sprites (same eye as the view).
        key = registry.get(unit.kind).split_key  # type: ignore[union-attr]
        keyed = sorted(
            ((key(lit, scene.solids[j].centre, cam), j) for j in inside), reverse=True
        )  # fmt: skip  (farthest first)
        plain = LitScene(scene.replace(solids=()), lit.lights)
        parts = painter.split(plain, k, cam, w, h, [z for z, _ in keyed])
        helper = Impostor(unit.kind, unit.k, unit.part)
        helper.plane0, helper.clamp = plane, state.screen
        shown = []
        for part in parts:
            helper.image = np.ascontiguousarray(part)
            helper.version += 1
            shown.append(painter.display([helper], camera, width, height, s.exact))
        painter.forget(helper)
        old = self._entries.pop(unit.key, None)
        if old is not None:
            painter.forget(old)
        solid_images = np.stack(
            [
                painter.solids(LitScene(scene.replace(solids=(scene.solids[j],)), lit.lights),
                               camera, width, height)
                for _, j in keyed
            ]
        )  # fmt: skip
        return composite_split(np.stack(shown), solid_images, getattr(painter, "threads", 0))
