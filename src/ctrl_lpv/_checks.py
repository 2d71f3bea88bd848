"""Argument checks shared by the public functions (not public)."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

__all__ = ["as_matrix", "as_ss_data", "real_number", "signal_indices"]


def real_number(
    value,
    name: str,
    *,
    allow_none: bool = False,
    minimum: float | None = None,
    positive: bool = False,
    below: float | None = None,
) -> float | None:
    """Return `value` as a finite float, naming `name` on error.

    Strings, booleans and complex numbers are refused with a `TypeError`;
    ``minimum`` (inclusive), ``positive`` (``> 0``) and ``below`` (exclusive
    upper bound) give a `ValueError` that states the admissible range.
    """
    if value is None:
        if allow_none:
            return None
        raise TypeError(f"{name}: expected a real number, got None")
    if isinstance(value, (bool, np.bool_, str, bytes)) or not isinstance(
        value, (int, float, np.integer, np.floating, np.ndarray)
    ):
        raise TypeError(f"{name}: expected a real number, got {value!r}")
    if isinstance(value, np.ndarray):
        if value.shape != () or not np.issubdtype(value.dtype, np.number):
            raise TypeError(f"{name}: expected a real number, got {value!r}")
        if np.iscomplexobj(value):
            raise TypeError(f"{name}: expected a real number, got {value!r}")
    number = float(value)
    if not np.isfinite(number):
        raise ValueError(f"{name}: must be finite, got {value!r}")
    if positive and not number > 0:
        raise ValueError(f"{name}: must be positive, got {value!r}")
    if minimum is not None and number < minimum:
        raise ValueError(f"{name}: must be at least {minimum:g}, got {value!r}")
    if below is not None and not number < below:
        raise ValueError(f"{name}: must be below {below:g}, got {value!r}")
    return number


def as_matrix(value, name: str, shape: tuple[int, int] | None = None) -> np.ndarray:
    """Return `value` as a finite 2-D float array, naming `name` on error."""
    try:
        raw = np.asarray(value)
    except (TypeError, ValueError):
        raise TypeError(f"{name}: expected a numeric matrix, got {value!r}") from None
    if raw.dtype.kind in "USVb":
        raise TypeError(f"{name}: expected a numeric matrix, got {value!r}")
    if raw.dtype.kind == "O":
        try:
            raw = raw.astype(complex)
        except (TypeError, ValueError):
            raise TypeError(
                f"{name}: expected a numeric matrix, got {value!r}"
            ) from None
    if np.iscomplexobj(raw):
        if np.any(raw.imag != 0):
            raise TypeError(
                f"{name}: complex entries are not supported (the imaginary "
                "part would be dropped)"
            )
        value = raw.real
    try:
        mat = np.array(value, dtype=float)
    except (TypeError, ValueError):
        raise TypeError(f"{name}: expected a numeric matrix, got {value!r}") from None
    if mat.ndim == 0 and shape is not None and mat == 0:
        mat = np.zeros(shape)
    elif mat.ndim < 2:
        mat = np.atleast_2d(mat)
    if mat.ndim != 2:
        raise ValueError(f"{name}: expected a 2-D matrix, got {mat.ndim} dimensions")
    if not np.all(np.isfinite(mat)):
        raise ValueError(f"{name}: entries must be finite (found nan or inf)")
    if shape is not None and mat.shape != tuple(shape):
        raise ValueError(f"{name}: expected shape {tuple(shape)}, got {mat.shape}")
    return mat


def as_ss_data(item, name: str) -> tuple[np.ndarray, ...]:
    """Return ``(A, B, C, D)`` of a `StateSpace` or a 4-tuple, checked."""
    from control import StateSpace

    if isinstance(item, StateSpace):
        if not item.isctime():
            raise ValueError(f"{name}: only continuous-time systems are supported")
        matrices = (item.A, item.B, item.C, item.D)
    elif isinstance(item, Sequence) and len(item) == 4:
        matrices = item
    else:
        raise TypeError(
            f"{name}: expected a control.StateSpace or an (A, B, C, D) tuple, "
            f"got {type(item).__name__}"
        )
    A = as_matrix(matrices[0], f"{name}.A")
    n = A.shape[0]
    if A.shape != (n, n):
        raise ValueError(f"{name}.A: must be square, got shape {A.shape}")
    if n == 0:
        raise ValueError(f"{name}.A: the system has no states")
    B = as_matrix(matrices[1], f"{name}.B")
    if B.shape[0] != n:
        if B.shape == (1, n):  # a 1-D input column written as a row
            B = B.T
        else:
            raise ValueError(f"{name}.B: expected {n} rows, got shape {B.shape}")
    C = as_matrix(matrices[2], f"{name}.C")
    if C.shape[1] != n:
        raise ValueError(f"{name}.C: expected {n} columns, got shape {C.shape}")
    D = as_matrix(matrices[3], f"{name}.D", shape=(C.shape[0], B.shape[1]))
    return A, B, C, D


def signal_indices(spec, labels: Sequence[str], name: str) -> list[int]:
    """Resolve signal names or indices in `spec` against `labels`.

    Raises a `ValueError` naming the argument for unknown names, indices out
    of range and repeated signals.
    """
    if spec is None:
        return []
    if isinstance(spec, (str, int, np.integer)):
        items = [spec]
    else:
        try:
            items = list(spec)
        except TypeError:
            raise TypeError(
                f"{name}: expected a signal name, an index or a list of them, "
                f"got {spec!r}"
            ) from None
    index = {label: i for i, label in enumerate(labels)}
    out = []
    for item in items:
        if isinstance(item, str):
            if item not in index:
                raise ValueError(
                    f"{name}: unknown signal {item!r}; available: {list(labels)}"
                )
            out.append(index[item])
        elif isinstance(item, (int, np.integer)) and not isinstance(item, bool):
            if not 0 <= item < len(labels):
                raise ValueError(
                    f"{name}: index {item} out of range for {len(labels)} signals"
                )
            out.append(int(item))
        else:
            raise TypeError(f"{name}: expected signal names or indices, got {item!r}")
    if len(set(out)) != len(out):
        raise ValueError(f"{name}: a signal is listed twice: {items}")
    return out
