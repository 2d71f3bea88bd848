"""Argument checks shared by the public functions (not public)."""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence

import numpy as np

__all__ = [
    "as_matrix",
    "as_ss_data",
    "checked_rates",
    "flag",
    "per_input",
    "positive_levels",
    "real_number",
    "signal_indices",
    "signal_labels",
    "signal_name",
    "signal_selection",
]


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


def flag(value, name: str) -> bool:
    """Return `value` as a bool, naming `name` on error.

    Only ``True``/``False`` (or numpy's booleans) are accepted: a string
    such as ``"no"``, a number or None would otherwise be read by its
    truth value, which is rarely what was meant.
    """
    if isinstance(value, (bool, np.bool_)):
        return bool(value)
    raise TypeError(f"{name}: expected True or False, got {value!r}")


def signal_name(value, name: str) -> str:
    """Return `value` as a signal (or system) name, naming `name` on error.

    A name is a non-empty `str`; bytes are refused rather than decoded (and
    rather than read as a sequence of integer indices).
    """
    if isinstance(value, str) and value:
        return value
    raise TypeError(f"{name}: expected a non-empty string, got {value!r}")


def signal_selection(value, name: str) -> tuple | None:
    """Return a selection of signals as a tuple of names and indices.

    `value` is a name, an index or a sequence of them (None stays None).
    Names are checked with `signal_name`; indices are integers, not
    booleans. Whether they exist is checked against the system later
    (`signal_indices`).
    """
    if value is None:
        return None
    if isinstance(value, (str, int, np.integer)) and not isinstance(value, bool):
        items = (value,)
    elif isinstance(value, (bytes, bytearray, bool, np.bool_)):
        items = (value,)  # refused below, by its own type
    else:
        try:
            items = tuple(value)
        except TypeError:
            raise TypeError(
                f"{name}: expected a signal name, an index or a sequence of them, "
                f"got {value!r}"
            ) from None
    for item in items:
        if isinstance(item, (int, np.integer)) and not isinstance(
            item, (bool, np.bool_)
        ):
            continue
        if not isinstance(item, str):
            raise TypeError(
                f"{name}: expected signal names (strings) or integer indices, "
                f"got {item!r}"
            )
    return items


def signal_labels(value, count: int, name: str) -> list[str] | None:
    """Check the ``inputs``/``outputs``/``states`` keyword of a system.

    None (the default names) and an integer equal to `count` pass through
    (as None); otherwise `count` distinct non-empty strings (a single
    string for ``count == 1``) are required.
    """
    if value is None:
        return None
    if isinstance(value, (int, np.integer)) and not isinstance(value, bool):
        if value != count:
            raise ValueError(f"{name}: {value} signals given for {count}")
        return None
    labels = [value] if isinstance(value, str) else signal_selection(value, name)
    for label in labels:
        signal_name(label, name)
    if len(labels) != count:
        raise ValueError(f"{name}: {len(labels)} names given for {count} signals")
    repeated = sorted({label for label in labels if labels.count(label) > 1})
    if repeated:
        raise ValueError(f"{name}: repeated names {repeated}; each must be unique")
    return list(labels)


def positive_levels(value, name: str) -> tuple[float, ...]:
    """Positive levels (a number or a flat sequence of them) as a tuple.

    Each level is checked with `real_number` (so ``"1"`` is refused) and
    kept below ``1e150``, so that its square stays finite in float64.
    """
    items = np.atleast_1d(np.asarray(value, dtype=object))
    if items.ndim != 1 or items.size == 0:
        raise ValueError(f"{name}: expected a level or a sequence, got {value!r}")
    return tuple(real_number(x, name, positive=True, below=1e150) for x in items)


def per_input(values, count: int, name: str, what: str) -> np.ndarray:
    """One level per input: a single level is repeated `count` times."""
    out = np.array(values * (count if len(values) == 1 else 1), float)
    if out.size != count:
        raise ValueError(f"{name}: {len(values)} levels for {count} {what}")
    return out


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
    if shape is not None and mat.size == 0 and 0 in shape:
        mat = np.zeros(shape)  # [] for a matrix with no rows or columns
    elif mat.ndim == 0 and shape is not None and mat == 0:
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
    if B.size == 0:  # no inputs, e.g. B = []
        B = np.zeros((n, 0))
    if B.shape[0] != n:
        if B.shape == (1, n):  # a 1-D input column written as a row
            B = B.T
        else:
            raise ValueError(f"{name}.B: expected {n} rows, got shape {B.shape}")
    C = as_matrix(matrices[2], f"{name}.C")
    if C.size == 0:  # no outputs, e.g. C = []
        C = np.zeros((0, n))
    if C.shape[1] != n:
        raise ValueError(f"{name}.C: expected {n} columns, got shape {C.shape}")
    D = as_matrix(matrices[3], f"{name}.D", shape=(C.shape[0], B.shape[1]))
    return A, B, C, D


def signal_indices(spec, labels: Sequence[str], name: str) -> list[int]:
    """Resolve signal names or indices in `spec` against `labels`.

    Raises a `ValueError` naming the argument for unknown names, indices out
    of range and repeated signals.
    """
    items = signal_selection(spec, name)
    if items is None:
        return []
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


def checked_rates(rate_bounds, names) -> np.ndarray:
    """``rate_bounds`` checked, one rate per parameter of `names`.

    A parameter not given (or given ``inf``) may vary arbitrarily fast.

    Raises
    ------
    TypeError
        `rate_bounds` is not a mapping, or a rate not a real number.
    ValueError
        An unknown parameter, or a negative or NaN rate (named).
    """
    if not isinstance(rate_bounds, Mapping):
        raise TypeError(
            f"rate_bounds: expected a mapping {{parameter: nu}}, got {rate_bounds!r}"
        )
    unknown = sorted(set(rate_bounds) - set(names))
    if unknown:
        raise ValueError(
            f"rate_bounds: unknown parameter(s) {unknown}; the plant has {list(names)}"
        )
    out = []
    for n in names:
        value = rate_bounds.get(n, math.inf)
        if isinstance(value, (float, np.floating)) and value == math.inf:
            out.append(math.inf)  # arbitrarily fast
        else:
            out.append(real_number(value, f"rate_bounds[{n!r}]", minimum=0.0))
    return np.array(out)
