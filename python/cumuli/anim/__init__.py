"""Animation stage: things that change over time — the endless animation (Iwasaki et al. 2011),
camera paths and frame sequences."""
