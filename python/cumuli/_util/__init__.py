"""Utilities every stage uses and no user calls: argument checks (``validate``), atomic file
writes (``atomic``), progress bars and interrupts (``progress``), bound-struct construction
(``structs``)."""
