"""Who reads a polytopic system: the calling frames, and warnings at them.

python-control's linear tools read ``sys.A, B, C, D`` directly (no method
receives ``params``), so the matrices of a polytopic system are properties
that look at the calling frames. Nothing in python-control is patched: the
lookup only reads the frames of the current call. Warnings are attributed
to the user's line, not to python-control's or this package's.
"""

from __future__ import annotations

import warnings
from collections.abc import Mapping

__all__ = ["given", "reader", "user_frame", "in_package", "warn_at", "call_name"]


def _module(frame) -> str:
    return frame.f_globals.get("__name__", "") if frame is not None else ""


def _in(package: str, module: str) -> bool:
    return module == package or module.startswith(package + ".")


def in_package(frame) -> bool:
    """Whether `frame` is code of ctrl_lpv itself (which reads silently)."""
    return _in("ctrl_lpv", _module(frame))


def given(params) -> bool:
    """Whether a ``params`` argument asks for something (not None or {})."""
    return params is not None and not (isinstance(params, Mapping) and not params)


def reader(frame):
    """Classify the code reading a polytopic system's matrices.

    Walks up from `frame` over python-control's frames (and the numpy or
    scipy frames between them) and returns ``(entry, caller, params)``: the
    outermost python-control frame of the call (None for a direct attribute
    access), the first frame outside these packages, and the ``params``
    argument of an enclosing time response of `control.timeresp`
    (``forced_response``, ``step_response``, ``initial_response``, ...), or
    None.
    """
    entry, params = None, None
    # numpy and scipy frames are crossed too: python-control's lambdas run
    # inside scipy.optimize (``bandwidth``) or numpy callbacks.
    while frame is not None and any(
        _in(pkg, _module(frame)) for pkg in ("control", "numpy", "scipy")
    ):
        if not _in("control", _module(frame)):
            frame = frame.f_back
            continue
        if (
            params is None
            and _module(frame) == "control.timeresp"
            and "params" in frame.f_code.co_varnames
        ):
            value = frame.f_locals.get("params")
            if given(value):
                params = value
        entry = frame
        frame = frame.f_back
    return entry, frame, params


def user_frame(frame):
    """First frame outside python-control, scipy, numpy and ctrl_lpv."""
    while frame is not None and any(
        _in(pkg, _module(frame)) for pkg in ("control", "scipy", "numpy", "ctrl_lpv")
    ):
        frame = frame.f_back
    return frame


def warn_at(message: str, category, frame) -> None:
    """Issue a warning attributed to the line of `frame`."""
    if frame is None:
        warnings.warn(message, category, stacklevel=3)
        return
    module_globals = frame.f_globals
    warnings.warn_explicit(
        message,
        category,
        frame.f_code.co_filename,
        frame.f_lineno,
        module=module_globals.get("__name__"),
        registry=module_globals.setdefault("__warningregistry__", {}),
    )


def call_name(entry, attribute: str) -> str:
    """User-facing name of the python-control call (or attribute) reading."""
    if entry is None:
        return f"reading sys.{attribute}"
    code = entry.f_code
    qualname = getattr(code, "co_qualname", code.co_name)
    if qualname.endswith("__call__"):
        return "sys(s)"
    return f"{_module(entry)}.{qualname}"
