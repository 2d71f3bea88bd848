"""One certificate type: named float64 checks and one rounding-aware test.

Every certified result of the library (a design, an analysis, a saturated
region, a gain file, the servo) carries a `Certificate`: an immutable
sequence of `Check` objects. A check is one number compared with a bound:
what was checked, where (vertex, point), in which units, strictly or not,
and the float64 rounding the comparison absorbs. A certificate is verified
when it has checks and every one passes; certificates compose with ``+``
(or `Certificate.combine`), and ``print`` shows them as a table.

Matrix inequalities ``F < -margin I`` are checked by one test,
`negative_definite` (`negative_definite_stack` for a stack of matrices),
with the rounding allowance `rounding_bound`, ``ROUNDING * k * eps *
||F||_2``.
"""

from __future__ import annotations

import html
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, fields, replace

import numpy as np

__all__ = [
    "ROUNDING",
    "Check",
    "Certificate",
    "rounding_bound",
    "negative_definite",
    "negative_definite_stack",
    "negative_definite_each",
]

#: Float64 rounding of an eigenvalue, per unit of size and norm.
#:
#: For a symmetric ``k x k`` float64 matrix ``F`` the computed eigenvalues
#: are within ``ROUNDING * k * eps * ||F||_2`` of the exact ones. LAPACK's
#: symmetric eigensolvers (numpy's ``eigvalsh``) are backward stable: they
#: return the exact eigenvalues of ``F + E`` with ``||E||_2 <= p(k) eps
#: ||F||_2``, ``p`` a modestly growing function of the size (LAPACK Users'
#: Guide, section 4.7), so by Weyl's inequality no eigenvalue moves by more
#: than ``||E||_2``. The Jacobi normalisation ``D F D`` of `negative_definite`
#: rounds each entry by at most ``2 eps`` relatively, at most ``2 sqrt(k) eps
#: ||D F D||_2`` in norm (the rounding of ``D`` itself is harmless: any
#: positive diagonal congruence keeps the inertia). ``100 k`` bounds both
#: with room for the worst cases of ``p`` (measured on matrices of known
#: spectra up to ``k = 256``: errors below ``k eps ||F||_2``). The relative
#: margins of the library's refusals (`ctrl_lpv.lmi.FarkasCertificate`)
#: assume the same bound.
ROUNDING = 100.0

_EPS = float(np.finfo(float).eps)


def rounding_bound(size: int, norm: float) -> float:
    """``ROUNDING * size * eps * norm``: the rounding a check absorbs, for a
    matrix of size `size` and 2-norm `norm` (or a bound on it, e.g. the norm
    of the same expression in absolute values, which also bounds the
    rounding of forming it)."""
    return ROUNDING * size * _EPS * float(norm)


@dataclass(frozen=True)
class Check:
    """One float64 check: `value` compared with `bound`.

    It passes when ``value + rounding < bound`` (`strict`; else ``<=``):
    the computed value, pushed up by the rounding of its computation, meets
    the bound, so the exact one does. A `cross_check` passes when ``value -
    rounding`` meets it: the exact value may. NaN fails.

    Attributes
    ----------
    what : str
        What is checked (e.g. ``"H-infinity vertex 0"``).
    value : float
        The computed quantity.
    bound : float
        What `value` must stay below.
    strict : bool
        Whether the comparison is strict (a strict matrix inequality, a
        Hurwitz test) or not (an inclusion, a side constraint).
    rounding : float
        Float64 rounding of `value` the comparison absorbs (0 for a value
        compared with a tolerance, or an LMI whose margin absorbs it).
    cross_check : bool
        Whether the check only cross-checks a statement other checks prove
        (e.g. an LMI in the model's units whose exactly congruent scaled
        form is proved with a margin): it passes unless float64 refutes it.
    units : str
        Units of `value`, `bound` and `rounding` (``"normalised"``: a
        Jacobi-normalised eigenvalue; ``"scaled"``: an LMI as posed to the
        solver).
    where : str
        The vertex, point or pair where the value was reached (the worst
        one when the check covers several).
    group : str
        Which statement of a composed certificate the check belongs to
        (``"LMI"``, ``"closed loop"``, ``"ultimate bound"``, ...).
    """

    what: str
    value: float
    bound: float
    strict: bool = False
    rounding: float = 0.0
    cross_check: bool = False
    units: str = ""
    where: str = ""
    group: str = ""

    def __post_init__(self):
        for name in ("value", "bound", "rounding"):
            object.__setattr__(self, name, float(getattr(self, name)))
        for name in ("strict", "cross_check"):
            object.__setattr__(self, name, bool(getattr(self, name)))
        if not self.rounding >= 0:
            raise ValueError(f"rounding: expected >= 0, got {self.rounding!r}")

    @property
    def slack(self) -> float:
        """How far inside (> 0) or outside the bound, rounding included."""
        sign = 1.0 if self.cross_check else -1.0
        return self.bound - self.value + sign * self.rounding

    @property
    def passed(self) -> bool:
        """Whether the value, rounding included, meets its bound."""
        return bool(self.slack > 0 if self.strict else self.slack >= 0)

    # The attribute names of the former `ctrl_lpv.lmi.LMICheck` and
    # `ctrl_lpv.reachability.EllipsoidCheck`, which users read.
    @property
    def name(self) -> str:
        """Alias of `what`."""
        return self.what

    @property
    def max_eig(self) -> float:
        """Alias of `value` (for an LMI, its largest eigenvalue)."""
        return self.value

    @property
    def required(self) -> float:
        """Alias of `bound`."""
        return self.bound

    @classmethod
    def from_lmi_check(cls, check, *, units="scaled", group="LMI") -> Check:
        """A `ctrl_lpv.lmi.LMICheck` (an LMI as posed, at the returned
        point) as a check; its margin absorbs the rounding."""
        if isinstance(check, Check):
            return replace(check, units=units, group=group)
        return cls(check.name, check.max_eig, check.required, check.strict,
                   units=units, group=group)  # fmt: skip

    def to_dict(self) -> dict:
        """A JSON object (non-finite numbers as ``"inf"``, ``"-inf"``,
        ``"nan"``); `from_dict` reads it back."""
        out = {f.name: getattr(self, f.name) for f in fields(self)}
        for key in ("value", "bound", "rounding"):
            if not math.isfinite(out[key]):
                out[key] = str(out[key])
        return out

    @classmethod
    def from_dict(cls, data: Mapping) -> Check:
        """The check `to_dict` wrote.

        Raises
        ------
        ValueError
            If `data` is not a mapping of the fields of a check.
        """
        known = {f.name for f in fields(cls)}
        if not isinstance(data, Mapping) or not (
            {"what", "value", "bound"} <= set(data) <= known
        ):
            raise ValueError(
                f"expected a mapping of {sorted(known)} (what, value, bound "
                f"required), got {data!r}"
            )
        return cls(**data)

    def cells(self) -> list[str]:
        """The row of this check in a certificate's table."""
        sign = "-" if self.cross_check else "+"
        return [
            self.group, self.what, self.where, f"{self.value:.4g}",
            "<" if self.strict else "<=", f"{self.bound:.4g}",
            f"{sign}{self.rounding:.2g}" if self.rounding else "0",
            self.units, "ok" if self.passed else "FAIL",
        ]  # fmt: skip


_HEADER = ("group", "check", "where", "value", "", "bound", "rounding", "units", "")
_NUMERIC = {3, 5, 6}  # right-aligned columns
_OPTIONAL = {0, 2, 7}  # shown only when some check has one


def _table(checks) -> tuple[list[str], list[list[str]], list[int]]:
    """Header, rows and kept column indices of a table of `checks`."""
    rows = [c.cells() for c in checks]
    keep = [i for i in range(len(_HEADER))
            if i not in _OPTIONAL or any(r[i] for r in rows)]  # fmt: skip
    return [_HEADER[i] for i in keep], [[r[i] for i in keep] for r in rows], keep


@dataclass(frozen=True)
class Certificate(Sequence):
    """Float64 checks of a result: an immutable sequence of `Check`.

    ``bool(certificate)`` is `verified`; ``a + b`` (or `combine`) is the
    certificate of both statements; ``print(certificate)`` shows the
    statement, a summary line and a table of the checks.

    Parameters
    ----------
    checks : sequence of `Check`
        Every check the statement rests on.
    statement : str, optional
        What the checks prove, in words.
    """

    checks: tuple[Check, ...] = ()
    statement: str = ""

    def __post_init__(self):
        checks = tuple(self.checks)
        for i, check in enumerate(checks):
            if not isinstance(check, Check):
                raise TypeError(
                    f"checks[{i}]: expected a Check, got {type(check).__name__}"
                )
        object.__setattr__(self, "checks", checks)

    def __len__(self) -> int:
        return len(self.checks)

    def __getitem__(self, index):
        return self.checks[index]

    @property
    def verified(self) -> bool:
        """Whether there are checks and every one passed."""
        return bool(self.checks) and all(c.passed for c in self.checks)

    def __bool__(self) -> bool:
        return self.verified

    @property
    def failed(self) -> tuple[Check, ...]:
        """The checks that did not pass."""
        return tuple(c for c in self.checks if not c.passed)

    @property
    def worst(self) -> Check | None:
        """The failed check, or else the check, with the least `slack`
        (compared as numbers across units); None without checks."""
        return min(self.checks, key=lambda c: (c.passed, c.slack), default=None)

    def group(self, name: str) -> tuple[Check, ...]:
        """The checks of one group (see `Check.group`)."""
        return tuple(c for c in self.checks if c.group == name)

    def __add__(self, other):
        if not isinstance(other, Certificate):
            return NotImplemented
        return Certificate.combine(self, other)

    @staticmethod
    def combine(*parts: Certificate, statement: str | None = None) -> Certificate:
        """One certificate of all `parts`: their checks and statements.

        Parameters
        ----------
        *parts : `Certificate`
            The certificates to combine.
        statement : str, optional
            The statement of the whole; default the parts' statements, one
            per line.

        """
        for i, part in enumerate(parts):
            if not isinstance(part, Certificate):
                raise TypeError(
                    f"parts[{i}]: expected a Certificate, got {type(part).__name__}"
                )
        if statement is None:
            statement = "\n".join(p.statement for p in parts if p.statement)
        return Certificate(sum((p.checks for p in parts), ()), statement)

    def regrouped(self, group: str) -> Certificate:
        """A copy whose checks belong to `group` (``"group: old"`` where a
        check had a group), to compose named parts."""
        return Certificate(
            tuple(replace(c, group=f"{group}: {c.group}" if c.group else group)
                  for c in self.checks),
            self.statement,
        )  # fmt: skip

    @property
    def summary(self) -> str:
        """One line: verified or not, how many checks, the worst one."""
        w = self.worst
        if w is None:
            return "NOT verified: no checks"
        at = f" at {w.where}" if w.where else ""
        if self.verified:
            return (
                f"verified: {len(self)} checks, least slack {w.what}{at} "
                f"({w.value:.3g} {'<' if w.strict else '<='} {w.bound:.3g})"
            )
        return (
            f"NOT verified: {len(self.failed)} of {len(self)} checks fail, worst "
            f"{w.what}{at} ({w.value:.3g} {'-' if w.cross_check else '+'} rounding "
            f"{w.rounding:.2g} not {'<' if w.strict else '<='} {w.bound:.3g})"
        )

    def __str__(self) -> str:
        lines = [self.statement] if self.statement else []
        lines.append(self.summary)
        if self.checks:
            header, rows, keep = _table(self.checks)
            widths = [max(len(r[i]) for r in [header, *rows])
                      for i in range(len(header))]  # fmt: skip

            def line(cells):
                return "  ".join(
                    c.rjust(w) if k in _NUMERIC else c.ljust(w)
                    for c, w, k in zip(cells, widths, keep)
                ).rstrip()

            lines += [line(header), line(["-" * w for w in widths])]
            lines += [line(r) for r in rows]
        return "\n".join(lines)

    def _repr_html_(self) -> str:
        header, rows, _ = _table(self.checks)

        def row(cells, tag):
            return "".join(f"<{tag}>{html.escape(c)}</{tag}>" for c in cells)

        body = "".join(f"<tr>{row(r, 'td')}</tr>" for r in rows)
        statement = html.escape(self.statement).replace("\n", "<br>")
        return (
            (f"<p>{statement}</p>" if statement else "")
            + f"<p><b>{html.escape(self.summary)}</b></p>"
            + f"<table><tr>{row(header, 'th')}</tr>{body}</table>"
        )

    def to_dict(self) -> dict:
        """A JSON object ``{"statement", "verified", "checks"}``;
        `from_dict` reads it back (``verified`` is informative)."""
        return {
            "statement": self.statement,
            "verified": self.verified,
            "checks": [c.to_dict() for c in self.checks],
        }

    @staticmethod
    def from_dict(data: Mapping) -> Certificate:
        """The `Certificate` (checks and statement) `to_dict` wrote.

        Raises
        ------
        ValueError
            If `data` is not such an object (naming the entry).
        """
        if not isinstance(data, Mapping) or not isinstance(data.get("checks"), list):
            raise ValueError("data: expected a mapping with a list 'checks'")
        statement = data.get("statement", "")
        if not isinstance(statement, str):
            raise ValueError("data['statement']: expected a string")
        checks = []
        for i, item in enumerate(data["checks"]):
            try:
                checks.append(Check.from_dict(item))
            except (TypeError, ValueError) as exc:
                raise ValueError(f"data['checks'][{i}]: {exc}") from None
        return Certificate(tuple(checks), statement)


def negative_definite(F, *, margin=0.0, absolute=None, cross_check=False,
                      what="F < 0", where="", units="", group="") -> Check:  # fmt: skip
    """Float64 check of ``F < -margin I``, rounding-aware.

    Without a margin only the sign matters, so the test is unit-free: with
    the Jacobi normalisation ``D F D``, ``D = |diag F|^-1/2`` (a congruence
    by a positive diagonal keeps the inertia), `value` is the largest
    eigenvalue of ``D F D`` and must lie below ``-rounding``, ``rounding =
    rounding_bound(k, ||D F D||_2)``. A nonnegative diagonal entry rules
    ``F < 0`` out: `value` is then at least that entry. With a margin the
    statement has the units of `F`: `value` is the largest eigenvalue of
    `F`, `bound` ``-margin`` and ``rounding = rounding_bound(k, ||F||_2)``.

    Parameters
    ----------
    F : array_like
        Square matrix (its symmetric part is checked).
    margin : float, optional
        Required distance below 0, in the units of `F`.
    absolute : array_like, optional
        The expression of `F` evaluated on absolute values (e.g. ``|A'| |P|
        + |P| |A|`` for ``A'P + PA``): forming `F` in float64 rounds each
        entry by a few ``eps`` times it, so its (normalised) norm replaces
        ``||F||`` in the rounding when larger. Default: `F` is exact.
    cross_check : bool, optional
        Only cross-check ``F < -margin I``, proved by other checks: pass
        unless float64 refutes it (see `Check.cross_check`).
    what, where, units, group : str, optional
        Labels of the check (see `Check`); `units` defaults to
        ``"normalised"`` for a normalised test.

    Returns
    -------
    `Check`
        A strict check.

    Raises
    ------
    ValueError
        If `F` is not a square matrix, `absolute` does not match it, or
        `margin` is negative (a non-finite `F` fails the check).
    """
    F = np.asarray(F, dtype=float)
    if F.ndim != 2:
        raise ValueError(f"F: expected a square matrix, got shape {F.shape}")
    stack = None if absolute is None else np.asarray(absolute, float)[None]
    return negative_definite_stack(
        F[None], margin=margin, absolute=stack, cross_check=cross_check,
        what=what, where=[where], units=units, group=group,
    )  # fmt: skip


def negative_definite_stack(F, *, margin=0.0, absolute=None, cross_check=False,
                            what="F < 0", where=None, units="",
                            group="") -> Check:  # fmt: skip
    """`negative_definite` of every matrix of a stack, as one check.

    Parameters
    ----------
    F : array_like
        Stack of square matrices, shape ``(p, k, k)``.
    margin, absolute, cross_check, what, units, group
        As in `negative_definite` (`absolute` a stack like `F`).
    where : sequence of str, optional
        Label of each matrix (default ``"[i]"``).

    Returns
    -------
    `Check`
        That of the matrix with the least slack: its value, rounding and
        label.

    Raises
    ------
    ValueError
        As `negative_definite`, or for an empty stack or `where` of the
        wrong length.
    """
    checks = negative_definite_each(
        F, margin=margin, absolute=absolute, cross_check=cross_check, what=what,
        where=where, units=units, group=group,
    )  # fmt: skip
    return max(checks, key=lambda c: c.value + (-c.rounding if cross_check
                                                else c.rounding))  # fmt: skip


def negative_definite_each(F, *, margin=0.0, absolute=None, cross_check=False,
                           what="F < 0", where=None, units="",
                           group="") -> tuple[Check, ...]:  # fmt: skip
    """`negative_definite` of every matrix of a stack, one check each.

    The same test, value and rounding as `negative_definite` on each
    matrix alone, with one stacked eigenvalue computation: the way to
    check many matrices of one size (the LMIs at a solver's point).

    Parameters
    ----------
    F : array_like
        Stack of square matrices, shape ``(p, k, k)``.
    margin, absolute, cross_check, units, group
        As in `negative_definite` (`absolute` a stack like `F`).
    what : str or sequence of str, optional
        Name of every check, or of each.
    where : sequence of str, optional
        Label of each matrix (default ``"[i]"``).

    Returns
    -------
    tuple of `Check`
        One strict check per matrix, in the order of the stack.

    Raises
    ------
    ValueError
        As `negative_definite_stack`, or for `what` of the wrong length.
    """
    F = np.asarray(F, dtype=float)
    if F.ndim != 3 or F.shape[1] != F.shape[2] or 0 in F.shape:
        raise ValueError(
            f"F: expected a non-empty stack of square matrices, got shape {F.shape}"
        )
    margin = float(margin)
    if not margin >= 0:
        raise ValueError(f"margin: expected >= 0, got {margin!r}")
    where = [f"[{i}]" for i in range(len(F))] if where is None else list(where)
    if len(where) != len(F):
        raise ValueError(f"where: expected {len(F)} labels, got {len(where)}")
    whats = [what] * len(F) if isinstance(what, str) else list(what)
    if len(whats) != len(F):
        raise ValueError(f"what: expected {len(F)} names, got {len(whats)}")
    # A matrix with a non-finite entry fails (value inf), checked as -I.
    finite = np.all(np.isfinite(F), axis=(1, 2))
    F = np.where(finite[:, None, None], F, -np.eye(F.shape[1]))
    F = 0.5 * (F + np.swapaxes(F, 1, 2))
    diag = np.diagonal(F, axis1=1, axis2=2)
    normalise = (margin == 0) & np.all(diag < 0, axis=1)
    d = 1.0 / np.sqrt(np.where(normalise[:, None], -diag, 1.0))
    eig = np.linalg.eigvalsh(F * d[:, :, None] * d[:, None, :])
    norm = np.abs(eig).max(axis=1)
    if absolute is not None:
        absolute = np.abs(np.asarray(absolute, dtype=float))
        if absolute.shape != F.shape:
            raise ValueError(
                f"absolute: expected shape {F.shape}, got {absolute.shape}"
            )
        scaled = 0.5 * (absolute + np.swapaxes(absolute, 1, 2)) * d[:, :, None]
        norm = np.maximum(norm, np.linalg.norm(scaled * d[:, None, :], 2, (1, 2)))
    rounding = rounding_bound(F.shape[1], 1.0) * norm
    value = eig[:, -1]
    if margin == 0:
        # A nonnegative diagonal entry decides alone: F < 0 is ruled out.
        value = np.where(normalise, value, np.maximum(value, diag.max(axis=1)))
    value = np.where(finite, value, np.inf)
    bound = -margin if margin else 0.0
    return tuple(
        Check(whats[i], float(value[i]), bound, True, float(rounding[i]), cross_check,
              units or ("normalised" if normalise[i] else ""), where[i], group)
        for i in range(len(F))
    )  # fmt: skip
