"""Light stage: the passes that turn a cloud and its lights into what a renderer reads."""

# Branch shim (harris): light.py moved to light/ndt.py as in the lead's layout; re-export its public
# names so that `from cumuli.light import light_grid` keeps working until the merge, where the
# lead's __init__.py (docstring only) replaces this file.
from cumuli.light.ndt import *  # noqa: F401,F403,E402
