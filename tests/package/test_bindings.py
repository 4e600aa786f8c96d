"""The core's bindings: no bound function takes a long argument list (grouped parameters travel
as bound structs), and the structs carry the render settings they are filled from."""

from __future__ import annotations

import inspect
import re

import numpy as np
import pytest

import cumuli as cu
from cumuli import _core
from cumuli.rendering.params import (
    MIN_TRANSMITTANCE,
    march_params,
    march_uniforms,
    physical_uniforms,
    sky_params,
    sky_uniforms,
    sun_params,
    viewport,
)
from cumuli.sky import sun_disc_edges

#: Most parameters a bound function or method may take (``self`` not counted).
MAX_PARAMETERS = 12


def _split_top_level(text: str) -> list[str]:
    """``text`` split at the commas outside brackets and quotes."""
    parts, depth, current, quote = [], 0, "", None
    for ch in text:
        if quote:
            quote = None if ch == quote else quote
        elif ch in "'\"":
            quote = ch
        elif ch in "([{<":
            depth += 1
        elif ch in ")]}>":
            depth -= 1
        elif ch == "," and depth == 0:
            parts.append(current)
            current = ""
            continue
        current += ch
    if current.strip():
        parts.append(current)
    return parts


def signature_counts(name: str, doc: str | None) -> list[int]:
    """Parameter counts (``self`` excluded) of every signature pybind11 wrote into ``doc``
    (``name(a: int, b: float) -> ...``; overloads are listed as ``1. name(...)``)."""
    counts = []
    for line in (doc or "").splitlines():
        line = re.sub(r"^\d+\.\s+", "", line.strip())
        if not line.startswith(name + "("):
            continue
        depth, end = 0, len(line)
        for i in range(len(name), len(line)):
            if line[i] == "(":
                depth += 1
            elif line[i] == ")":
                depth -= 1
                if depth == 0:
                    end = i
                    break
        inner = line[len(name) + 1 : end]
        if inner.strip() == "*args, **kwargs":  # the header of an overload set
            continue
        params = [p.strip() for p in _split_top_level(inner)]
        counts.append(len([p for p in params if p and not p.startswith("self")]))
    return counts


def bound_callables() -> list[tuple[str, str, str | None]]:
    """(qualified name, name, docstring) of every function of ``_core`` and every method of its
    classes (``__init__`` included; pybind11's private helpers left out)."""
    out = []
    for name, obj in vars(_core).items():
        if name.startswith("__"):
            continue
        if inspect.isclass(obj):
            for mname, member in vars(obj).items():
                if callable(member) and (mname == "__init__" or not mname.startswith("_")):
                    out.append((f"{name}.{mname}", mname, getattr(member, "__doc__", None)))
        elif callable(obj):
            out.append((name, name, obj.__doc__))
    return out


def test_signature_parser_counts_parameters():
    doc = (
        "f(a: typing.Annotated[list[float], 'FixedSize(3)'], b: tuple[int, int] = (1, 2), "
        "c: str = 'x, y') -> dict[str, int]\n\nDoc, with (commas)."
    )
    assert signature_counts("f", doc) == [3]
    assert signature_counts("m", "m(self: X, a: int) -> None") == [1]
    overloads = "g(*args, **kwargs)\nOverloaded function.\n\n1. g(a: int) -> int\n\n2. g() -> int"
    assert signature_counts("g", overloads) == [1, 0]


def test_no_bound_callable_takes_more_than_twelve_parameters():
    callables = bound_callables()
    counted = [(q, signature_counts(n, doc)) for q, n, doc in callables]
    # Every function has a signature in its docstring (the check is not vacuous).
    missing = [q for q, c in counted if not c and not q.endswith("__init__")]
    assert not missing, f"no signature found in the docstrings of {missing}"
    assert len(counted) > 100
    offenders = {q: max(c) for q, c in counted if c and max(c) > MAX_PARAMETERS}
    assert not offenders, f"bound callables with more than {MAX_PARAMETERS} parameters: {offenders}"


SETTINGS = cu.RenderSettings(
    kappa=0.4, absorption=1.7, lod_a=0.3, lod_delta=0.01, step_ref=0.2, step_min=0.03,
    step_max=0.9, fixed_step=0.0, hg_g=0.45, max_steps=1234, max_candidates=17, march="union",
    candidate_sort="none", octaves=4, gain=0.6, lacunarity=2.5, frequency=0.7, jitter=True,
    jitter_seed=9, empty_space_skipping=False, min_transmittance=0.01,
lighting="paper")  # fmt: skip


def test_march_params_carry_the_render_settings():
    p = march_params(SETTINGS)
    f32 = np.float32
    assert p.absorption == f32(1.7) and p.lod_a == f32(0.3) and p.lod_delta == f32(0.01)
    assert p.ref_step == f32(0.2) and p.step_min == f32(0.03) and p.step_max == f32(0.9)
    assert p.fixed_step == 0.0 and p.hg_g == f32(0.45)
    assert (p.max_steps, p.max_candidates, p.march) == (1234, 17, "union")
    assert p.sort_candidates is False and p.skip_empty is False and p.jitter is True
    assert p.min_transmittance == f32(0.01) and p.phys.jitter_seed == 9
    assert (p.fbm.octaves, p.fbm.gain, p.fbm.lacunarity, p.fbm.frequency) == (
        4, f32(0.6), f32(2.5), f32(0.7),
    )  # fmt: skip
    assert p.physical is False and p.density_constant < 0
    p.validate()
    # The GL uniforms are read from the same struct.
    u = march_uniforms(p, exact_noise=True)
    assert u["u_step_ref"] == p.ref_step and u["u_union"] is True and u["u_exact"] is True
    assert u["u_octaves"] == 4 and u["u_jitter_seed"] == 9 and u["u_skip_empty"] is False
    assert u["u_max_candidates"] == 17 and u["u_gain"] == f32(0.6)


def test_march_params_of_the_physical_mode():
    s = SETTINGS.replace(lighting="physical", phase="dual_hg", hg_g2=-0.2, hg_blend=0.3)
    p = march_params(s, physical_octaves=3)
    f32 = np.float32
    assert p.physical and p.phys.dual_hg and p.phys.octaves == 3 and p.phys.jitter_seed == 9
    assert p.phys.g1 == f32(0.45) and p.phys.g2 == f32(-0.2) and p.phys.blend == f32(0.3)
    assert p.phys.extinction_scale == f32(s.extinction_scale) and p.phys.albedo == f32(s.albedo)
    assert p.phys.min_transmittance == f32(MIN_TRANSMITTANCE)
    p.validate()
    u = physical_uniforms(p.phys)  # the GL uniforms come from the same struct
    assert u["u_phys_octaves"] == 3 and u["u_phys_dual"] is True and u["u_phys_seed"] == 9
    assert u["u_phys_g"] == (p.phys.g1, p.phys.g2, p.phys.blend)


def test_sun_sky_and_view_structs():
    sky = cu.Sky(zenith=(0.1, 0.2, 0.3), horizon=(0.4, 0.5, 0.6), exponent=0.7,
                 sun_disc_radius=2.0, sun_disc_intensity=3.0)  # fmt: skip
    sun = cu.Sun(direction=(0.0, 0.6, 0.8), colour=(1.0, 0.9, 0.8), intensity=2.0)
    k = sky_params(sky)
    assert np.allclose(k.zenith, (0.1, 0.2, 0.3)) and np.allclose(k.horizon, (0.4, 0.5, 0.6))
    assert k.exponent == np.float32(0.7) and k.sun_disc_radius == 2.0
    assert k.sun_disc_intensity == 3.0
    s = sun_params(sun)
    assert np.allclose(s.direction, sun.direction) and np.allclose(s.radiance, sun.radiance)
    u = sky_uniforms(sky, sun)
    assert u["u_sun_disc"] == sun_disc_edges(2.0) and u["u_sun_disc_intensity"] == 3.0
    cam = cu.Camera(position=(1, 2, 3), target=(0, 0, 0), fov=35)
    v = viewport(cam, 40, 30)
    assert (v.width, v.height, v.camera.fov) == (40, 30, 35.0)
    assert np.allclose(v.camera.position, (1, 2, 3))
    v.validate()


@pytest.mark.parametrize(
    "field, value, match",
    [
        ("absorption", float("inf"), "absorption"),
        ("step_min", 0.0, "step_min"),
        ("step_max", 0.001, "step_max"),
        ("hg_g", 1.0, "hg_g"),
        ("max_steps", 0, "max_steps"),
        ("max_candidates", 0, "max_candidates"),
        ("min_transmittance", 1.0, "min_transmittance"),
    ],
)
def test_march_settings_refuse_what_render_settings_refuse(field, value, match):
    rs_name = {"ref_step": "step_ref"}.get(field, field)
    with pytest.raises(ValueError, match=match):
        SETTINGS.replace(**{rs_name: value})
    p = march_params(SETTINGS)
    setattr(p, field, value)
    with pytest.raises(ValueError, match=match):
        p.validate()


def test_structs_refuse_bad_values():
    with pytest.raises(ValueError, match="octaves"):
        _core.FbmParams(0, 0.5, 2.0, 1.0).validate()
    with pytest.raises(ValueError, match="march"):
        march_params(SETTINGS).march = "twice"
    with pytest.raises(ValueError, match="camera up"):
        _core.CameraParams().up = (1.0, 2.0)
    with pytest.raises(ValueError, match="sun direction"):
        _core.SunParams().direction = (0.0, float("nan"), 1.0)
    with pytest.raises(ValueError, match="width"):
        _core.Viewport(_core.CameraParams(), 0, 10).validate()
    with pytest.raises(AttributeError):
        march_params(SETTINGS).no_such_field = 1
