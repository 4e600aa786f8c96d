"""The registration of every kind of drawable: one module per kind, each making one
:class:`cumuli.registry.Kind` that says what every stage asks of the kind (see ARCHITECTURE.md,
"Adding a kind"). Importing this package registers them all, in the order scene files and error
messages list them."""

# isort: off
from cumuli.kinds import cloud  # noqa: F401 (registers the kind)
from cumuli.kinds import volume  # noqa: F401
from cumuli.kinds import particles  # noqa: F401
from cumuli.kinds import billboards  # noqa: F401
from cumuli.kinds import deck  # noqa: F401
# isort: on
