"""Notebooks run by the test runner (nbmake) run in quick mode: small sizes. Opened by a
person they run at full size (their parameters read CUMULI_QUICK, default "0")."""

import os

os.environ.setdefault("CUMULI_QUICK", "1")
os.environ.setdefault("CUMULI_PROGRESS", "0")
