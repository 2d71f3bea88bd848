"""numba, the optional compiler of the ``compiled`` simulation engine.

The library works without numba (the scipy engines); the compiled engine
and the compiled plant stepping of `sampled_response` need it. Install it
with ``pip install "ctrl_lpv[fast]"``.
"""

from __future__ import annotations

import importlib.util

__all__ = ["numba_available", "require_numba"]

INSTALL = 'pip install "ctrl_lpv[fast]"  (or: pip install numba)'


def numba_available() -> bool:
    """True if numba can be imported (checked without importing it)."""
    return importlib.util.find_spec("numba") is not None


def require_numba(what: str) -> None:
    """Raise `ImportError` naming `what` unless numba is installed."""
    if not numba_available():
        raise ImportError(
            f"{what} needs numba, which is not installed: {INSTALL}. "
            "Without it, use engine='fast' (scipy)."
        )
