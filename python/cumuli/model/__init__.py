"""Model stage: what a cloud is, before any light.

`cloud` (the 2018 paper's primitive clouds), its generators `gaussian`, `lsystem`, `mesh`
(Jiménez de Parga & Gómez Palomo 2018, §3.6) and `volume` (density volumes and the endless
animation's database, Iwasaki et al. 2011), `particles` (Harris 2002's particle clouds) and
`solid` (opaque spheres placed in clouds). Nothing here depends on light or rendering.
"""
