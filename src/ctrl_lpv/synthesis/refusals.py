"""The one refusal format of the engine's ladder.

Every refusal of a design (the ladder `ctrl_lpv.synthesis.hooked.climb`,
for state feedback through `ctrl_lpv.synthesis.general.run`, for output
feedback with the hook of `ctrl_lpv.output_feedback.stages`) reads the same: a
short first line (what was asked, the best point reached), what failed
(the ladder's notes without repeats, `ctrl_lpv.budget.digest`), a hint
where the data show a likely cause, and what was tried.
"""

from __future__ import annotations

from .. import budget
from ..exceptions import CertificationError

__all__ = ["refusal"]


def refusal(method, best, notes, tried, attempts, hint="") -> CertificationError:
    """The `CertificationError` of a ladder that found no certified point.

    Parameters
    ----------
    method : str
        The call (the first word of the message).
    best : str or None
        The best point reached (a certified point or an estimate).
    notes : sequence of str
        What failed, in order (``"where: why"``; the place is dropped, the
        reasons are digested).
    tried : str
        What the ladder tried (rungs, prescalings, solvers, margins).
    attempts : sequence
        The solver attempts (the error's ``attempts``).
    hint : str, optional
        A likely cause, kept whole after the digested reasons.
    """
    reasons = budget.digest("; ".join(note.split(": ", 1)[-1] for note in notes))
    return CertificationError(
        f"{method}: no certified solution found, best point reached: "
        f"{'none' if best is None else best}\n"
        f"what failed: {reasons}{hint}\n"
        f"tried: {tried}",
        attempts,
    )
