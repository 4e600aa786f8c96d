"""Light stage: the passes that turn a cloud, a sun and a sky into the light a renderer reads.

`ndt` (the 2018 paper's NDT light grids), `volume` (Iwasaki et al. 2011's sun, SH sky and
multiple scattering of density volumes), `prepare` (the explicit light step of a scene).
"""
