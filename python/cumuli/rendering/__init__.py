"""Rendering stage: one drawer per kind of cloud (GL and its C++ CPU twin) and the compositor.

`compositor` (`render`, `Renderer`: every kind drawn as a premultiplied layer and composited over
the sky), `marcher` (the 2018 paper's ray marcher), `volume` (density volumes), `cpu` (the CPU
twins' dispatch), `kinds` (which drawer draws which kind).
"""
