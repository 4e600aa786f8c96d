"""The C++ reference marcher (backend="cpu") against a slow numpy twin of RENDER_CONTRACT.

The numpy marcher below follows the contract operation by operation in float32 scalars (the same
order of operations as cpp/src/rendering/marcher.cpp, so interval ends and step counts agree), on
tiny images: agreement is then at the level of libm's last bits (exp, pow, sqrt), far below 1e-5.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from test_physical import _jitter  # RENDER_CONTRACT "Camera rays": ξ of a pixel

import cumuli as cu
import cumuli.rendering.marcher_cpu
from cumuli import _core
from cumuli._util.structs import core_struct

F = np.float32
EYE3 = np.eye(3, dtype=np.float32)


# --------------------------------------------------------------------------------------------
# Scene builders (plain core arguments)
def cloud_dict(centres, radii, model="spheroid", kappa=0.5, phi=0.6, light=None, seed=0):
    centres = np.asarray(centres, np.float32)
    radii = np.asarray(radii, np.float32)
    if radii.ndim == 1:
        radii = np.repeat(radii[:, None], 3, axis=1)
    n = len(centres)
    lo = (centres - radii).min(0) - 0.5
    hi = (centres + radii).max(0) + 0.5
    if light is None:  # a smooth but non-constant grid, so the trilinear lookup matters
        rng = np.random.default_rng(seed)
        light = (0.3 + 0.7 * rng.random((5, 4, 6))).astype(np.float32)
    return {
        "centres": centres,
        "radii": radii,
        "rotations": np.repeat(EYE3[None], n, axis=0),
        "model": model,
        "kappa": kappa,
        "phi": phi,
        "light": light,
        "light_lo": tuple(float(v) for v in lo),
        "light_hi": tuple(float(v) for v in hi),
    }


def make_args(clouds, width=8, height=6, **over):
    args = {
        "camera_position": (0.3, 0.4, -6.0),
        "camera_target": (0.2, 0.1, 0.0),
        "camera_up": (0.0, 1.0, 0.0),
        "fov": 40.0,
        "width": width,
        "height": height,
        "clouds": clouds,
        "sun_direction": (0.3, 0.8, -0.52),
        "sun_radiance": (1.2, 1.1, 0.9),
        "sky_zenith": (0.2, 0.4, 0.85),
        "sky_horizon": (0.6, 0.75, 0.95),
        "sky_ground": (0.3, 0.3, 0.32),
        "sky_exponent": 0.45,
        "sun_disc_radius": 3.0,
        "sun_disc_intensity": 5.0,
        "absorption": 1.3,
        "lod_a": 0.12,
        "lod_delta": 0.01,
        "ref_step": 0.1,
        "step_min": 0.02,
        "step_max": 1.0,
        "fixed_step": 0.0,
        "hg_g": 0.6,
        "max_steps": 4096,
        "max_candidates": 64,
        "march": "paper",
        "octaves": 5,
        "gain": 0.5,
        "lacunarity": 2.0,
        "frequency": 0.6,
        "noise": None,
        "threads": 0,
        "density_constant": 0.3,
    }
    args.update(over)
    return args


def core_render(**a):
    """``_core.render_cpu`` from the flat arguments of `make_args`, packed into the core's
    structs (the numpy reference below reads the flat ones)."""
    a = dict(a)
    cam = core_struct(
        _core.CameraParams, position=a.pop("camera_position"), target=a.pop("camera_target"),
        up=a.pop("camera_up"), fov=a.pop("fov"),
    )  # fmt: skip
    view = _core.Viewport(cam, a.pop("width"), a.pop("height"))
    sun = core_struct(
        _core.SunParams, direction=a.pop("sun_direction"), radiance=a.pop("sun_radiance")
    )
    sky = core_struct(
        _core.SkyParams, zenith=a.pop("sky_zenith"), horizon=a.pop("sky_horizon"),
        ground=a.pop("sky_ground"), exponent=a.pop("sky_exponent"),
        sun_disc_radius=a.pop("sun_disc_radius"), sun_disc_intensity=a.pop("sun_disc_intensity"),
    )  # fmt: skip
    settings = _core.MarchSettings()
    for name in MARCH_FIELDS:
        if name in a:
            setattr(settings, name, a.pop(name))
    settings.fbm = _core.FbmParams(
        a.pop("octaves"), a.pop("gain"), a.pop("lacunarity"), a.pop("frequency")
    )
    settings.phys.jitter_seed = a.pop("jitter_seed", 0)
    return _core.render_cpu(view, a.pop("clouds"), sun, sky, settings, **a)


MARCH_FIELDS = (
    "absorption", "lod_a", "lod_delta", "ref_step", "step_min", "step_max", "fixed_step", "hg_g",
    "max_steps", "max_candidates", "march", "sort_candidates", "density_constant",
    "min_transmittance", "skip_empty", "jitter",
)  # fmt: skip


def flat_args(core: dict) -> dict:
    """The flat arguments of `make_args` from the core's (structs) keyword arguments."""
    view, sun, sky, st = core["view"], core["sun"], core["sky"], core["settings"]
    out = {
        "camera_position": view.camera.position, "camera_target": view.camera.target,
        "camera_up": view.camera.up, "fov": view.camera.fov, "width": view.width,
        "height": view.height, "sun_direction": sun.direction, "sun_radiance": sun.radiance,
        "sky_zenith": sky.zenith, "sky_horizon": sky.horizon, "sky_ground": sky.ground,
        "sky_exponent": sky.exponent, "sun_disc_radius": sky.sun_disc_radius,
        "sun_disc_intensity": sky.sun_disc_intensity, "octaves": st.fbm.octaves,
        "gain": st.fbm.gain, "lacunarity": st.fbm.lacunarity, "frequency": st.fbm.frequency,
        "jitter_seed": st.phys.jitter_seed,
    }  # fmt: skip
    out.update({name: getattr(st, name) for name in MARCH_FIELDS})
    out.update({k: v for k, v in core.items() if k not in ("view", "sun", "sky", "settings")})
    return out


def two_spheres(**kw):
    return cloud_dict([[0.0, 0.0, 0.0], [1.1, 0.3, 0.2]], [1.0, 0.8], **kw)


# --------------------------------------------------------------------------------------------
# The numpy reference marcher (float32 scalars; same operation order as the C++)
def v3(x):
    return np.asarray(x, dtype=np.float32).reshape(3)


def dot(a, b):
    t = a * b
    return F(F(t[0] + t[1]) + t[2])


def normalize(v):
    return v * (F(1) / np.sqrt(dot(v, v)))


def cross(a, b):
    return np.array(
        [a[1] * b[2] - b[1] * a[2], a[2] * b[0] - b[2] * a[0], a[0] * b[1] - b[0] * a[1]],
        dtype=np.float32,
    )


class RefCloud:
    def __init__(self, d, eye, args):
        self.c = np.asarray(d["centres"], np.float32)
        self.r = np.asarray(d["radii"], np.float32)
        self.model = d["model"]
        self.kappa = F(d["kappa"])
        self.phi = F(d["phi"])
        self.light = np.asarray(d["light"], np.float32)
        self.llo, self.lhi = v3(d["light_lo"]), v3(d["light_hi"])
        n = len(self.c)
        self.scale = F(math.sqrt(n)) if self.model == "metaball" else F(1)
        self.box_lo = (self.c - self.r * self.scale).min(0)
        self.box_hi = (self.c + self.r * self.scale).max(0)
        lo, hi = (self.c - self.r).min(0), (self.c + self.r).max(0)
        centre = F(0.5) * (lo + hi)
        self.mean_r2 = F(np.mean([float(dot(r, r)) / 3.0 for r in self.r]))
        if args["fixed_step"] > 0:
            self.step = F(args["fixed_step"])
        else:
            dist = np.sqrt(dot(eye - centre, eye - centre))
            step = F(args["lod_a"]) * np.exp(-F(args["lod_delta"]) * dist)
            self.step = F(min(max(step, F(args["step_min"])), F(args["step_max"])))

    def candidates(self, o, d, tmin, tmax, cap):
        out = []
        for j in range(len(self.c)):
            rad = self.r[j] * self.scale
            oo = (o - self.c[j]) / rad
            dd = d / rad
            a, b, c = dot(dd, dd), dot(oo, dd), dot(oo, oo) - F(1)
            disc = b * b - a * c
            if disc < 0:
                continue
            s = np.sqrt(disc)
            t0, t1 = max((-b - s) / a, tmin), min((-b + s) / a, tmax)
            if not t1 > t0:
                continue
            out.append((F(t0), F(t1), j))
        out.sort(key=lambda c: c[0])  # stable: equal t_in keep primitive order, as insertion
        return out[:cap]

    def qdist(self, j, p):
        q = (p - self.c[j]) / self.r[j]
        return np.sqrt(dot(q, q))

    def density(self, j, p, src):
        if self.model == "metaball":
            field = F(0)
            for k in range(len(self.c)):
                q = (p - self.c[k]) / self.r[k]
                d2 = dot(q, q)
                if d2 <= F(1e-12):
                    return F(src(p) * self.mean_r2 * self.phi), F(1)
                field = F(field + F(1) / d2)
                if field >= 1:
                    break
            if field < 1:
                return F(0), F(0)
            return F(src(p) * self.mean_r2 * self.phi), F(1)
        q = self.qdist(j, p)
        if q > 1:
            return F(0), F(0)
        rho = src(p)
        gamma = np.exp(-q / ((F(1) - self.kappa) + F(2) * self.kappa * rho))
        return (F(rho), gamma) if rho < gamma else (F(0), gamma)

    def light_at(self, p):
        nz, ny, nx = self.light.shape
        res = np.array([nx, ny, nz], np.float32)
        u = (p - self.llo) / (self.lhi - self.llo) * res - F(0.5)
        f = np.floor(u)
        w = u - f
        i0 = [int(min(max(f[k], 0), res[k] - 1)) for k in range(3)]
        i1 = [int(min(max(f[k] + 1, 0), res[k] - 1)) for k in range(3)]
        L = self.light

        def at(x, y, z):
            return L[z, y, x]

        x0, y0, z0 = i0
        x1, y1, z1 = i1
        c00 = at(x0, y0, z0) + w[0] * (at(x1, y0, z0) - at(x0, y0, z0))
        c10 = at(x0, y1, z0) + w[0] * (at(x1, y1, z0) - at(x0, y1, z0))
        c01 = at(x0, y0, z1) + w[0] * (at(x1, y0, z1) - at(x0, y0, z1))
        c11 = at(x0, y1, z1) + w[0] * (at(x1, y1, z1) - at(x0, y1, z1))
        c0 = c00 + w[1] * (c10 - c00)
        c1 = c01 + w[1] * (c11 - c01)
        return F(c0 + w[2] * (c1 - c0))


def ref_fbm(lattice, args):
    size = lattice.shape[0]
    octaves, gain, lac, freq = (
        args["octaves"],
        F(args["gain"]),
        F(args["lacunarity"]),
        F(args["frequency"]),
    )

    def lat(u):
        x = u - F(0.5)
        f = np.floor(x)
        w = x - f
        i0 = [int(f[k]) % size for k in range(3)]
        i1 = [(i + 1) % size for i in i0]

        def t(a, b, c):
            return lattice[c, b, a]

        (x0, y0, z0), (x1, y1, z1) = i0, i1
        c00 = t(x0, y0, z0) + w[0] * (t(x1, y0, z0) - t(x0, y0, z0))
        c10 = t(x0, y1, z0) + w[0] * (t(x1, y1, z0) - t(x0, y1, z0))
        c01 = t(x0, y0, z1) + w[0] * (t(x1, y0, z1) - t(x0, y0, z1))
        c11 = t(x0, y1, z1) + w[0] * (t(x1, y1, z1) - t(x0, y1, z1))
        c0 = c00 + w[1] * (c10 - c00)
        c1 = c01 + w[1] * (c11 - c01)
        return c0 + w[2] * (c1 - c0)

    def fbm(p):
        s, amp, scale = F(0), F(1), freq
        for _ in range(octaves):
            amp = F(amp * gain)
            scale = F(scale * lac)
            s = F(s + amp * lat(p * scale))
        return s

    return fbm


def ref_sky(args, d):
    hor, zen, gnd = v3(args["sky_horizon"]), v3(args["sky_zenith"]), v3(args["sky_ground"])
    sun_dir = normalize(v3(args["sun_direction"]))
    if d[1] >= 0:
        base = hor + (zen - hor) * np.power(d[1], F(args["sky_exponent"]))
    else:
        base = hor + (gnd - hor) * min(F(1), F(-8) * d[1])
    rad = F(args["sun_disc_radius"]) * F(0.017453292519943295)
    e0, e1 = np.cos(F(1.5) * rad), np.cos(rad)
    t = min(max((dot(d, sun_dir) - e0) / (e1 - e0), F(0)), F(1))
    w = t * t * (F(3) - F(2) * t)
    return base + w * F(args["sun_disc_intensity"]) * v3(args["sun_radiance"])


class RefRay:
    """One ray of the reference marcher: transmittance, colour and the sample count."""

    def __init__(self, ctx, d):
        self.ctx, self.d = ctx, d
        self.col = np.zeros(3, np.float32)
        self.T = F(1)
        self.n = 0
        g = ctx["g"]
        g2 = g * g
        denom = F(1) + g2 - F(2) * g * dot(d, ctx["sun_dir"])
        self.phase = (F(1) - g2) / (F(12.566370614359172) * np.power(denom, F(1.5)))

    def sample(self, c, jp, s):
        ctx = self.ctx
        p = ctx["eye"] + s * self.d
        rho, gamma = c.density(jp, p, ctx["src"])
        self.n += 1
        if rho > 0:
            dtau = np.exp(-ctx["absorption"] * rho * c.step / ctx["ref_step"])
            aL = ctx["radiance"] * c.light_at(p)
            sL = aL * self.phase * gamma
            self.col = self.col + ((F(1) - dtau) * (aL + sL)) * self.T
            self.T = F(self.T * dtau)
            if self.T < F(1e-6):
                return False
        return self.n < ctx["args"]["max_steps"]

    def owner(self, c, cand, jp, s):
        if c.model != "spheroid":
            return jp
        p = self.ctx["eye"] + s * self.d
        best, owner = np.inf, jp
        for m_in, m_out, mp in cand:
            if m_in > s:
                break
            if s > m_out:
                continue
            q = c.qdist(mp, p)
            if q < best:
                best, owner = q, mp
        return owner

    def march_cloud(self, c, t_min, t_max, xi):
        args = self.ctx["args"]
        cand = c.candidates(self.ctx["eye"], self.d, t_min, t_max, args["max_candidates"])
        half = xi * c.step
        if args["march"] == "paper":
            for t_in, t_out, jp in cand:
                t = t_in
                while t < t_out:
                    if not self.sample(c, jp, F(t + half)):
                        return False
                    t = F(t + c.step)
            return True
        t = -np.inf
        for t_in, t_out, jp in cand:
            if t_out <= t:
                continue
            t = max(t, t_in)
            while t < t_out:
                s = F(t + half)
                if not self.sample(c, self.owner(c, cand, jp, s), s):
                    return False
                t = F(t + c.step)
        return True


def ref_render(args, lattice=None):
    W, H = args["width"], args["height"]
    eye = v3(args["camera_position"])
    f = normalize(v3(args["camera_target"]) - eye)
    r = normalize(cross(f, v3(args["camera_up"])))
    u = cross(r, f)
    th = np.tan(F(args["fov"]) * F(0.017453292519943295) / F(2))
    aspect = F(W) / F(H)
    if args.get("density_constant", -1.0) >= 0:
        const = F(args["density_constant"])

        def src(p):
            return const
    else:
        src = ref_fbm(lattice, args)
    ctx = {
        "args": args,
        "eye": eye,
        "src": src,
        "g": F(args["hg_g"]),
        "sun_dir": normalize(v3(args["sun_direction"])),
        "radiance": v3(args["sun_radiance"]),
        "absorption": F(args["absorption"]),
        "ref_step": F(args["ref_step"]),
    }
    clouds = [RefCloud(c, eye, args) for c in args["clouds"]]
    img = np.zeros((H, W, 4), np.float32)
    for i in range(H):
        for j in range(W):
            x = (F(2) * (F(j) + F(0.5)) / F(W) - F(1)) * th * aspect
            y = (F(1) - F(2) * (F(i) + F(0.5)) / F(H)) * th
            d = normalize((f + x * r) + y * u)
            inv = F(1) / d
            hits = []
            for k, c in enumerate(clouds):
                ta, tb = (c.box_lo - eye) * inv, (c.box_hi - eye) * inv
                t0, t1 = np.minimum(ta, tb).max(), np.maximum(ta, tb).min()
                if t0 > t1 or not t1 >= 0:
                    continue
                hits.append((max(t0, F(0)), t1, k))
            hits.sort(key=lambda h: h[0])  # stable, like the C++ insertion sort
            ray = RefRay(ctx, d)
            xi = _jitter(i, j, args.get("jitter_seed", 0)) if args.get("jitter") else F(0.5)
            for t_min, t_max, k in hits:
                if not ray.march_cloud(clouds[k], t_min, t_max, xi):
                    break
            img[i, j, :3] = ray.col + ray.T * ref_sky(args, d)
            img[i, j, 3] = F(1) - ray.T
    return img


# --------------------------------------------------------------------------------------------
@pytest.mark.parametrize("march", ["paper", "union"])
def test_constant_density_matches_numpy_reference(march):
    args = make_args([two_spheres()], march=march)
    img = core_render(**args)
    ref = ref_render(args)
    assert img.shape == (6, 8, 4) and img.dtype == np.float32
    assert (img[..., 3] > 0.5).sum() >= 4, "the test scene must actually show the cloud"
    np.testing.assert_allclose(img, ref, atol=1e-5, rtol=0)


@pytest.mark.parametrize("march", ["paper", "union"])
def test_jittered_samples_match_numpy_reference(march):
    # settings.jitter: each pixel's samples at ξ·Δ into their step instead of Δ/2.
    args = make_args([two_spheres()], march=march, jitter=True, jitter_seed=7, width=12, height=9)
    img = core_render(**args)
    ref = ref_render(args)
    np.testing.assert_allclose(img, ref, atol=1e-5, rtol=0)
    plain = core_render(**{**args, "jitter": False})
    assert np.abs(img - plain).max() > 1e-3  # the offsets do move the samples
    assert not np.array_equal(core_render(**{**args, "jitter_seed": 8}), img)  # its seed


@pytest.mark.parametrize("march", ["paper", "union"])
def test_fbm_density_matches_numpy_reference(march):
    noise = _core.Noise(3, 16)
    args = make_args(
        [cloud_dict([[0.0, 0.0, 0.0], [0.9, 0.2, 0.0]], [1.2, 1.0], kappa=0.9)],
        march=march,
        noise=noise,
        density_constant=-1.0,
        frequency=2.0,
    )
    img = core_render(**args)
    ref = ref_render(args, np.asarray(noise.lattice))
    assert (img[..., 3] > 0.05).sum() >= 4
    np.testing.assert_allclose(img, ref, atol=1e-5, rtol=0)


def test_metaball_and_two_clouds_match_numpy_reference():
    meta = cloud_dict(
        [[-0.3, 0.0, 0.0], [0.4, 0.2, 0.1], [0.0, -0.3, 0.3]],
        [0.5, 0.4, 0.45],
        model="metaball",
        phi=0.6,
        seed=1,
    )
    far = cloud_dict([[2.0, 0.5, 4.0]], [1.5], seed=2)
    args = make_args([far, meta], absorption=2.0, density_constant=0.5)
    img = core_render(**args)
    ref = ref_render(args)
    assert (img[..., 3] > 0.5).sum() >= 2
    np.testing.assert_allclose(img, ref, atol=1e-5, rtol=0)


def test_thread_count_does_not_change_a_bit():
    noise = _core.Noise(5, 32)
    args = make_args([two_spheres()], width=40, height=30, noise=noise, density_constant=-1.0)
    one = core_render(**{**args, "threads": 1})
    for t in (2, 3, 7):
        assert np.array_equal(one, core_render(**{**args, "threads": t}))


def test_no_cloud_gives_the_sky_exactly():
    args = make_args([], width=8, height=6)
    img = core_render(**args)
    assert (img[..., 3] == 0).all()
    np.testing.assert_allclose(img, ref_render(args), atol=1e-6, rtol=0)
    # A cloud the camera looks away from changes nothing either.
    behind = make_args([cloud_dict([[0.0, 0.0, -20.0]], [1.0])])
    assert np.array_equal(core_render(**behind), img)


def test_paper_equals_union_where_primitives_are_disjoint():
    disjoint = cloud_dict([[-1.2, 0.0, 0.0], [1.2, 0.0, 0.5]], [1.0, 0.9])
    args = make_args([disjoint], width=24, height=18)
    paper = core_render(**{**args, "march": "paper"})
    union = core_render(**{**args, "march": "union"})
    assert (paper[..., 3] > 0.5).sum() > 20
    assert np.array_equal(paper, union)


def test_paper_marches_overlaps_twice():
    # Two concentric-ish spheres: along rays through both, paper marches the overlap twice.
    args = make_args(
        [cloud_dict([[0.0, 0.0, 0.0], [0.1, 0.0, 0.0]], [1.0, 1.0])],
        width=24,
        height=18,
        absorption=0.1,
        density_constant=0.2,
    )
    paper = core_render(**{**args, "march": "paper"})
    union = core_render(**{**args, "march": "union"})
    covered = union[..., 3] > 0.05
    assert covered.sum() > 20
    # Never less opaque; rays through both spheres see about twice the optical depth (thin
    # medium, near-identical chords), rays grazing one sphere only are the same in both modes.
    assert (paper[..., 3] >= union[..., 3]).all()
    tau_p = -np.log1p(-paper[..., 3].astype(np.float64))
    tau_u = -np.log1p(-union[..., 3].astype(np.float64))
    both = covered & (tau_p > 1.05 * tau_u)
    assert both.sum() > covered.sum() // 2
    ratio = np.median(tau_p[both] / tau_u[both])
    assert 1.7 < ratio < 2.1, ratio
    # The centre ray passes through both spheres along nearly the same chord.
    assert 1.8 < tau_p[9, 12] / tau_u[9, 12] < 2.05


def test_camera_inside_a_cloud_is_finite_and_covered():
    noise = _core.Noise(1, 16)
    args = make_args(
        [cloud_dict([[0.0, 0.0, 0.0]], [3.0])],
        camera_position=(0.1, 0.2, 0.3),
        camera_target=(0.0, 0.0, 5.0),
        noise=noise,
        density_constant=-1.0,
        width=16,
        height=12,
    )
    img = core_render(**args)
    assert np.isfinite(img).all()
    assert (img[..., 3] > 0).all()  # every ray starts inside the sphere
    np.testing.assert_allclose(
        img[:3, :4],
        ref_render({**args, "width": 16, "height": 12}, np.asarray(noise.lattice))[:3, :4],
        atol=1e-5,
        rtol=0,
    )


def test_max_steps_caps_the_march():
    args = make_args([two_spheres()], absorption=0.05, density_constant=0.2)
    full = core_render(**args)
    capped = core_render(**{**args, "max_steps": 3})
    covered = full[..., 3] > 0.05  # rays with more than three samples in the cloud
    assert covered.any()
    assert (capped[..., 3] <= full[..., 3]).all()
    assert (capped[..., 3][covered] < full[..., 3][covered]).all()
    np.testing.assert_allclose(capped, ref_render({**args, "max_steps": 3}), atol=1e-5, rtol=0)


def test_max_candidates_keeps_the_nearest():
    # Three spheres on the view axis; with one candidate only the nearest is marched.
    row = cloud_dict([[0.0, 0.0, 2.0], [0.0, 0.0, -2.0], [0.0, 0.0, 0.0]], [0.8, 0.8, 0.8])
    args = make_args(
        [row], camera_position=(0.0, 0.0, -8.0), camera_target=(0.0, 0.0, 0.0), absorption=0.2
    )
    one = core_render(**{**args, "max_candidates": 1})
    np.testing.assert_allclose(one, ref_render({**args, "max_candidates": 1}), atol=1e-5, rtol=0)
    all3 = core_render(**args)
    assert all3[3, 4, 3] > one[3, 4, 3] > 0


def test_early_exit_makes_dense_clouds_opaque():
    args = make_args([two_spheres()], absorption=50.0, density_constant=0.3)
    img = core_render(**args)
    assert img[..., 3].max() >= 1 - 1e-6
    np.testing.assert_allclose(img, ref_render(args), atol=1e-5, rtol=0)


# --------------------------------------------------------------------------------------------
# Bad input
@pytest.mark.parametrize(
    "change, match",
    [
        ({"width": 0}, "width"),
        ({"height": -3}, "height"),
        ({"width": 1 << 20}, "width"),
        ({"fov": 0.0}, "fov"),
        ({"fov": float("nan")}, "fov"),
        ({"camera_position": (0.0, float("nan"), 0.0)}, "camera position"),
        ({"camera_target": (0.3, 0.4, -6.0)}, "target"),
        ({"camera_up": (0.0, 0.0, 1.0), "camera_target": (0.3, 0.4, 0.0)}, "up"),
        ({"camera_up": (1.0, 2.0)}, "camera up"),
        ({"sun_direction": (0.0, 0.0, 0.0)}, "sun direction"),
        ({"march": "twice"}, "march"),
        ({"max_steps": 0}, "max_steps"),
        ({"max_candidates": 0}, "max_candidates"),
        ({"max_candidates": 1 << 20}, "max_candidates"),
        ({"step_min": 0.0}, "step_min"),
        ({"step_max": 0.001}, "step_max"),
        ({"ref_step": -1.0}, "ref_step"),
        ({"hg_g": 1.0}, "hg_g"),
        ({"absorption": float("inf")}, "absorption"),
        ({"octaves": 0, "density_constant": -1.0}, "octaves"),
        ({"density_constant": -1.0}, "noise"),
        ({"threads": -1}, "threads"),
        ({"sky_exponent": 0.0}, "exponent"),
    ],
)
def test_bad_arguments_raise_clear_errors(change, match):
    with pytest.raises(ValueError, match=match):
        core_render(**make_args([two_spheres()], **change))


@pytest.mark.parametrize(
    "change, match",
    [
        ({"light": np.zeros((4, 4), np.float32)}, "light"),
        ({"light": np.full((2, 2, 2), np.nan, np.float32)}, "NaN"),
        ({"light_lo": (0.0, 0.0, 0.0), "light_hi": (1.0, 0.0, 1.0)}, "light_box"),
        ({"light_hi": (1.0, float("nan"), 1.0)}, "light_hi"),
        ({"radii": np.zeros((2, 3), np.float32)}, "radii"),
        ({"centres": np.full((2, 3), np.nan, np.float32)}, "centres"),
        ({"rotations": np.zeros((2, 3), np.float32)}, "rotations"),
        ({"model": "blob"}, "model"),
        ({"kappa": 2.0}, "kappa"),
    ],
)
def test_bad_clouds_raise_clear_errors(change, match):
    cloud = {**two_spheres(), **change}
    with pytest.raises(ValueError, match=match):
        core_render(**make_args([cloud]))


def test_cloud_missing_a_field_or_not_a_dict():
    cloud = two_spheres()
    del cloud["light"]
    with pytest.raises(ValueError, match=r"clouds\[0\].*light"):
        core_render(**make_args([cloud]))
    with pytest.raises(TypeError, match=r"clouds\[0\]"):
        core_render(**make_args([42]))


# --------------------------------------------------------------------------------------------
# The Python entry point on scene objects
def scene_cloud(centres, radii, **kw):
    import cumuli as cu

    d = cloud_dict(centres, radii, **kw)
    cloud = cu.Cloud(centres=d["centres"], radii=d["radii"], kappa=d["kappa"])
    return cloud, cu.LightGrid(d["light"], (d["light_lo"], d["light_hi"]))


def test_render_cpu_on_scene_objects_follows_the_contract():
    import cumuli as cu

    cloud, grid = scene_cloud([[0.0, 0.0, 0.0], [1.1, 0.3, 0.2]], [1.0, 0.8], kappa=0.3)
    settings = cu.RenderSettings(
        kappa=0.7, frequency=1.5, march="union", lod_a=0.1, lighting="paper"
    )
    scene = cu.Scene(clouds=[cloud], noise=cu.Noise(seed=4, size=16), settings=settings)
    scene = cu.prepare_light(scene, lights=[grid])  # the hand-made grid, used as it is
    camera = cu.Camera(position=(0.3, 0.4, -6.0), target=(0.2, 0.1, 0.0), fov=40)
    img = cu.render_cpu(scene, camera, 8, 6)
    args = flat_args(cumuli.rendering.marcher_cpu.render_cpu_args(scene, camera, 8, 6))
    assert args["clouds"][0]["kappa"] == pytest.approx(0.7)  # settings.kappa overrides the cloud's
    assert args["ref_step"] == np.float32(settings.step_ref) and args["march"] == "union"
    assert (img[..., 3] > 0.05).sum() >= 4
    lattice = np.asarray(scene.scene.noise.lattice)
    np.testing.assert_allclose(img, ref_render(args, lattice), atol=1e-5)


def test_render_cpu_sky_agrees_with_the_scene_sky_reference():
    import cumuli as cu

    scene = cu.Scene(
        clouds=[],
        sky=cu.Sky.sunset(),
        sun=cu.Sun(direction=(0.2, 0.05, 1.0)),
        settings=cu.RenderSettings(lighting="paper"),
    )
    camera = cu.Camera(position=(0.0, 1.0, 0.0), target=(0.2, 1.05, 5.0), fov=60)
    img = cu.render_cpu(scene, camera, 32, 24)
    dirs = camera.ray_directions(32, 24)
    np.testing.assert_allclose(img[..., :3], scene.sky.colour(dirs, scene.sun), atol=2e-5, rtol=0)
    assert (img[..., 3] == 0).all()
    # The sun disc is in view and bright.
    assert img[..., :3].max() > 5


def test_render_cpu_bad_arguments():
    import cumuli as cu

    scene = cu.Scene(
        clouds=[scene_cloud([[0.0, 0.0, 0.0]], [1.0])[0]],
        settings=cu.RenderSettings(lighting="paper"),
    )
    camera = cu.Camera(position=(0.0, 0.0, -5.0), target=(0.0, 0.0, 0.0))
    with pytest.raises(ValueError, match="width"):
        cu.render_cpu(scene, camera, 0, 4)
    with pytest.raises(TypeError, match="height"):
        cu.render_cpu(scene, camera, 4, 2.5)
    with pytest.raises(ValueError, match="threads"):
        cu.render_cpu(scene, camera, 4, 4, threads=-2)


def test_render_cpu_computes_missing_light_grids_and_dispatches():
    import cumuli as cu

    cloud = cu.Cloud(centres=[[0.0, 0.0, 0.0], [1.0, 0.2, 0.0]], radii=[1.0, 0.8])
    scene = cu.Scene(
        clouds=[cloud],
        noise=cu.Noise(seed=2, size=16),
        settings=cu.RenderSettings(light_resolution=6, lod_a=0.1, lighting="paper"),
    )
    camera = cu.Camera(position=(0.5, 0.5, -6.0), target=(0.5, 0.0, 0.0))
    img = cu.render_cpu(scene, camera, 12, 9)
    assert cu.prepare_light(scene).lights[0].shape == (6, 6, 6)  # made on demand
    assert not hasattr(cloud, "light")  # and not stored on the cloud
    assert (img[..., 3] > 0.05).sum() >= 4
    # cumuli.render(backend="cpu") is this marcher.
    assert np.array_equal(cu.render(scene, camera, 12, 9, backend="cpu"), img)
    with pytest.raises(TypeError, match="scene"):
        cu.render_cpu("scene", camera, 4, 4)
    with pytest.raises(TypeError, match="camera"):
        cu.render_cpu(scene, (0, 0, 0), 4, 4)


def test_rotation_columns_are_the_ellipsoid_axes():
    # Radii (2, 1, 0.7) with axes (+y, +z, +x) (the rotation's columns) is the axis-aligned
    # ellipsoid with radii (0.7, 2, 1): the two images agree (an exact permutation matrix; only
    # the summation order of |q|² differs, so agreement is to float rounding).
    noise = _core.Noise(9, 16)
    light = np.random.default_rng(4).random((4, 5, 6)).astype(np.float32)
    aligned = cloud_dict([[0.2, 0.1, 0.0]], np.array([[0.7, 2.0, 1.0]]), light=light)
    rotated = {**aligned, "radii": np.array([[2.0, 1.0, 0.7]], np.float32)}
    rotated["rotations"] = np.array([[[0, 0, 1], [1, 0, 0], [0, 1, 0]]], np.float32)
    args = make_args([aligned], width=20, height=15, noise=noise, density_constant=-1.0)
    a = core_render(**args)
    b = core_render(**{**args, "clouds": [rotated]})
    assert (a[..., 3] > 0.05).sum() > 10
    np.testing.assert_allclose(a, b, atol=1e-5, rtol=0)
    # Rows as axes would be another ellipsoid (radii (1, 0.7, 2)): visibly different.
    wrong = {**rotated, "rotations": np.transpose(rotated["rotations"], (0, 2, 1)).copy()}
    c = core_render(**{**args, "clouds": [wrong]})
    assert np.abs(c - a)[..., 3].max() > 0.2


def test_axis_aligned_rays_with_zero_direction_components():
    # Odd image, camera on the z axis: the centre ray is exactly (0, 0, 1), so the slab test sees
    # 1/0 = inf (and 0·inf where the ray lies in a slab plane). A uniform light grid and constant
    # density make the image mirror-symmetric.
    cloud = cloud_dict([[0.0, 0.0, 0.0]], [1.0], light=np.full((3, 3, 3), 0.7, np.float32))
    cloud["light_lo"], cloud["light_hi"] = (-1.0, -1.0, -1.0), (1.0, 1.0, 1.0)
    args = make_args(
        [cloud],
        width=9,
        height=7,
        camera_position=(0.0, 0.0, -6.0),
        camera_target=(0.0, 0.0, 0.0),
        sun_direction=(0.0, 1.0, 0.0),
    )
    img = core_render(**args)
    assert np.isfinite(img).all()
    assert img[3, 4, 3] > 0.5  # the centre ray goes through the middle of the sphere
    np.testing.assert_allclose(img[..., 3], img[:, ::-1, 3], atol=1e-6)
    # The middle row (d.y = 0) and column (d.x = 0) cross the sphere like their neighbours.
    assert (img[2:5, 3:6, 3] > 0.5).all()
    assert (img[[0, 1, 5, 6], :, 3] == 0).all() and (img[:, [0, 1, 2, 6, 7, 8], 3] == 0).all()


def test_jitter_trades_the_step_rings_of_a_dense_cloud_for_noise_that_averages_out():
    # A metaball cloud is entered within a step or two, so at a fixed Δ/2 offset the first
    # sample's depth jumps in whole steps from pixel to pixel: contour rings, an error that 4×4
    # averaging keeps. Jittered offsets make it a pixel-scale pattern that the averaging removes.
    scene = cu.Scene([cu.metaball_cumulus(seed=2)], settings=cu.RenderSettings(lighting="paper"))
    camera = scene.default_camera()

    def render(**changes):
        return cu.render_cpu(
            scene.replace(settings=scene.settings.replace(**changes)), camera, 96, 72
        )

    def block_mean(img):
        return img.reshape(18, 4, 24, 4, 4).mean(axis=(1, 3))

    reference = block_mean(render(fixed_step=0.01))  # 15 times finer: no visible rings
    inside = reference[..., 3] > 0.5
    assert inside.sum() > 100

    def error(img):
        return float(np.abs(block_mean(img) - reference)[inside][:, :3].mean())

    plain = error(render(fixed_step=0.15))
    jittered = error(render(fixed_step=0.15, jitter=True))
    assert jittered < 0.85 * plain, (plain, jittered)  # measured 0.0049 → 0.0034
