"""Rendering stage: one drawer per kind of cloud (GL and its C++ CPU twin)."""
