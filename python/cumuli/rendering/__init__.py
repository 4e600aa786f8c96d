"""Rendering stage: one drawer per kind of cloud (GL and its C++ CPU twin) and the compositor.

`compositor` (`render`, `Renderer`: every kind drawn as a premultiplied layer and composited over
the sky), `marcher` (the 2018 paper's ray marcher), `volume` (density volumes), `cpu` (the CPU
twins' dispatch), `particles` / `particle_layers` (Harris 2002's eye pass and the particle
kind's drawers), `solids` (opaque spheres), `impostors` / `impostor_cache` / `impostor_gl`
(Harris 2002's dynamic impostors for every kind), `painters` (what the compositor asks of a
backend), `fidelity` (Harris's approximations measured), `kinds` (which drawer draws which
kind).
"""
