"""Animation stage: time-dependent skies and clouds."""
