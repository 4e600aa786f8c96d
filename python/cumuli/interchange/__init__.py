"""Clouds that travel: volume files any drawable with a density can be written to and any
volume read from (:mod:`.volumes`), and whole scenes handed to Mitsuba 3 (:mod:`.mitsuba`) and
Blender (:mod:`.blender`). Optional packages are imported only when a function needs them."""
