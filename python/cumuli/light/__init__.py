"""Light stage: the passes that turn a cloud, a sun and a sky into the light a renderer reads.

`ndt` (the 2018 paper's NDT light grids), `volume` (Iwasaki et al. 2011's sun, SH sky and
multiple scattering of density volumes), `particles` (Harris 2002's multiple forward
scattering of particle clouds), `prepare` (the explicit light step of a scene).
"""
