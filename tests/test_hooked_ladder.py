"""The engine's one ladder (`ctrl_lpv.synthesis.hooked`): for a problem
that supplies its stages, driven by a scripted hook (the order of the
stages, the held raw optimum, the renormalisation and the refusal, against
the rules stated in the module's docstring; the output-feedback numerics
themselves are gated by the output-feedback tests and
`benchmarks/compare_output_feedback.py`), and on a corpus of state- and
output-feedback problems against the two loops it replaced."""

from __future__ import annotations

import re
from dataclasses import dataclass

import pytest

from ctrl_lpv import CertificationError
from ctrl_lpv.synthesis.hooked import Posed, StageHook, ladder, run_rung

RAW = (0.0, 1e-5, 1e-4, 5e-4)


@dataclass
class Design:
    gamma: float
    scale: float = 1.0
    backoff: float | None = None
    timing: dict | None = None
    ladder: tuple = ()


@dataclass(frozen=True)
class Rung:
    label: str
    name: str
    slow: bool = False


class ScriptedPosed(Posed):
    """A rung whose optimum is ``estimate * scale`` and whose points certify
    at ``gamma(b)`` (None: refused)."""

    def __init__(self, hook, rung, scale):
        self.hook, self.rung, self.scale = hook, rung, scale

    def optimal(self):
        self.hook.log.append(("optimal", self.rung.name, self.scale))
        if self.hook.no_optimum:
            raise CertificationError("scripted: no optimum", ())
        return "optimal"

    def estimate(self, point):
        return self.hook.estimate * self.scale

    def backoff_stages(self, optimal, b, estimate):
        if b == 0:
            return [lambda: optimal]

        def stage():
            self.hook.log.append(("center", self.rung.name, b))
            return f"center {b:g}"

        return [stage]

    def check(self, point, b, estimate, limit):
        self.hook.limits.append(limit)
        gamma = self.hook.certifies(self.rung, self.scale, b)
        if gamma is None:
            raise CertificationError(f"scripted: {self.rung.name} refused at {b:g}", ())
        gamma *= self.scale
        if gamma > limit:
            raise CertificationError(f"scripted: {gamma:g} above {limit:g}", ())
        return Design(gamma, self.scale, b)


class ScriptedHook(StageHook):
    prefix = "scripted: "
    method = "scripted"

    def __init__(self, certifies, estimate=1.0, backoffs=RAW, homogeneous=True,
                 names=("first",)):  # fmt: skip
        super().__init__()
        self.certifies = certifies
        self.estimate = estimate
        self._backoffs = backoffs
        self.homogeneous = homogeneous
        self.names = names
        self.no_optimum = False
        self.log, self.limits = [], []

    def rungs(self):
        return [Rung(f"rung {n}", n) for n in self.names]

    def pose(self, rung, scale):
        return ScriptedPosed(self, rung, scale)

    def backoffs(self):
        return self._backoffs

    def in_units(self, design, scale, limit):
        self.limits.append(limit)
        return Design(design.gamma / scale, 1.0, design.backoff)

    def reached(self, design, label):
        return f"certified on {label}"

    def estimated(self, estimate):
        return f"estimate {estimate:g}"

    def tried(self):
        return f"rungs {list(self.names)}"


def test_raw_optimum_above_its_estimate_is_held_until_a_backoff_fits_it():
    """The raw optimum certifies at 3e-5 above its estimate: it is not the
    answer of back-off 0 nor of 1e-5 (whose stage is solved and refused),
    and is returned as the answer of 1e-4 without solving that stage."""
    hook = ScriptedHook(lambda rung, scale, b: 1.0 + 3e-5 if b == 0 else None)
    design, failure, estimate = run_rung(hook, hook.rungs()[0])
    assert failure is None and estimate == 1.0
    assert design.backoff == 0 and design.gamma == 1.0 + 3e-5
    centers = [entry[2] for entry in hook.log if entry[0] == "center"]
    assert centers == [1e-5]
    # The raw optimum is checked within the largest raw back-off.
    assert hook.limits[0] == pytest.approx((1 + 5e-4) * (1 + 1e-6))


def test_backoff_asked_for_comes_first_then_the_raw_sequence():
    """backoff 0.2: the back-off stage first, certified within 1.2 times
    the estimate; when it is refused, the raw optimum, checked within the
    back-off asked for."""
    hook = ScriptedHook(lambda rung, scale, b: 1.1 if b == 0.2 else None,
                        estimate=1.0, backoffs=(0.2, *RAW))  # fmt: skip
    design, _, _ = run_rung(hook, hook.rungs()[0])
    assert design.backoff == 0.2 and design.gamma == 1.1
    assert hook.limits == [pytest.approx(1.2 * (1 + 1e-6))]

    hook = ScriptedHook(lambda rung, scale, b: 1.0 if b == 0 else None,
                        backoffs=(0.2, *RAW))  # fmt: skip
    design, _, _ = run_rung(hook, hook.rungs()[0])
    assert design.backoff == 0
    assert hook.limits[1] == pytest.approx(1.2 * (1 + 1e-6))


@pytest.mark.parametrize("estimate", [1e3, 3e-4])
def test_renormalised_once_on_failure_by_a_power_of_two(estimate):
    """A refused rung whose estimate is far from one is posed again with z
    scaled by a power of two s (s * estimate within [1/sqrt 2, sqrt 2]),
    and the design certified in the plant's units within the back-off of
    the first estimate."""
    hook = ScriptedHook(lambda rung, scale, b: None if scale == 1.0 else estimate,
                        estimate=estimate, backoffs=(0.2, *RAW))  # fmt: skip
    design, failure, found = run_rung(hook, hook.rungs()[0])
    scales = [s for kind, _, s in hook.log if kind == "optimal"]
    assert scales[0] == 1.0 and len(scales) == 2
    s = scales[1]
    assert float(s).hex().startswith("0x1.0000000000000p")  # a power of two
    assert 2**-0.5 <= s * estimate <= 2**0.5
    assert failure is None and found == estimate
    assert design.gamma == pytest.approx(estimate)
    assert hook.limits[-1] == pytest.approx(1.2 * estimate * (1 + 1e-3))


def test_no_renormalisation_of_a_non_homogeneous_problem_or_near_one():
    for estimate, homogeneous in ((1e3, False), (1.5, True)):
        hook = ScriptedHook(lambda rung, scale, b: None, estimate=estimate,
                            homogeneous=homogeneous)  # fmt: skip
        design, failure, _ = run_rung(hook, hook.rungs()[0])
        assert design is None and isinstance(failure, CertificationError)
        assert [s for kind, _, s in hook.log if kind == "optimal"] == [1.0]


def test_ladder_takes_the_first_rung_that_certifies_and_refuses_with_every_note():
    hook = ScriptedHook(lambda rung, scale, b: 1.0 if rung.name == "second" else None,
                        names=("first", "second", "third"))  # fmt: skip
    design = ladder(hook)
    assert design.gamma == 1.0
    assert {name for _, name, _ in hook.log} == {"first", "second"}
    # The rung passed over is the design's ladder, by name and reason.
    assert design.ladder == ("first: first refused at 0.0005",)
    assert sorted(design.timing) == ["build", "compile", "solve", "verify"]

    hook = ScriptedHook(lambda rung, scale, b: None, estimate=1.5,
                        names=("first", "second"))  # fmt: skip
    with pytest.raises(CertificationError) as info:
        ladder(hook)
    # The engine's refusal: the best point reached (the smallest estimate)
    # first, then the last refusal of each rung without the prefix, digested,
    # and what was tried.
    first, failed, tried = str(info.value).splitlines()
    assert first == ("scripted: no certified solution found, best point reached: "
                     "estimate 1.5")  # fmt: skip
    assert failed == "what failed: first refused at 0.0005; second refused at 0.0005"
    # Where the time went (no solver attempts or certificates here).
    assert re.fullmatch(r"tried: rungs \['first', 'second'\]; time [0-9.e-]+ s", tried)


def test_a_rung_without_an_optimum_gives_no_estimate():
    hook = ScriptedHook(lambda rung, scale, b: 1.0, estimate=1e3)
    hook.no_optimum = True
    with pytest.raises(CertificationError) as info:
        ladder(hook)
    first, failed, _ = str(info.value).splitlines()
    assert first.endswith("best point reached: none")
    assert "no optimum" in failed


def test_a_rung_after_the_deadline_is_not_tried(monkeypatch):
    """The one ladder's budget: rungs past the call's deadline are noted
    as not tried, without a solve."""
    from ctrl_lpv import budget

    monkeypatch.setattr(budget, "deadline", lambda: float("-inf"))
    hook = ScriptedHook(lambda rung, scale, b: 1.0, names=("first", "second"))
    with pytest.raises(CertificationError) as info:
        ladder(hook)
    assert hook.log == []
    assert "time_limit reached" in str(info.value)


# ----------------------------------------------------------------------
# One ladder: the corpus decides as the two loops did (issue 20)
# ----------------------------------------------------------------------
# Outcomes recorded from the separate state-feedback (`run`) and
# output-feedback (`run_hooked`) loops at commit 1f84be3, before they
# became one (`tests/_ladder_corpus.py`). On the machine that recorded them
# the one ladder gave the same bits; on another the solver's path follows
# its BLAS kernels (measured on an AVX2 machine against the AVX-512 one of
# the recording: fuzz 2026:1's ill-conditioned optimum 5.10 against 5.40,
# gains of 6e8 that differ by 5 %, raw output-feedback designs landing on
# another of the back-offs 1e-5..5e-4). So the corpus is compared by what
# is the same on every machine: the verdict, the refusal's first line with
# its numbers masked, and each certified bound no worse than the recorded
# one beyond the largest raw back-off. Each bound is the design's own
# float64 certificate (recomputed independently in
# tests/test_trust_fuzz.py for the fuzz cases). Cases over ~3 s of CPU run
# with ``-m slow``.
_CORPUS_SLOW = {"fuzz 2026:6 (small) quadratic_stabilization", "hinf_of 2-vertex",
                "h2_of 2 raw"}  # fmt: skip


def _corpus():
    import json
    from pathlib import Path

    from _ladder_corpus import cases

    recorded = json.loads((Path(__file__).parent / "data" / "ladder_corpus.json")
                          .read_text())  # fmt: skip
    return [
        pytest.param(call, recorded[name], id=name,
                     marks=[pytest.mark.slow] if name in _CORPUS_SLOW else [])
        for name, call in cases()
    ]  # fmt: skip


_NUMBER = re.compile(r"[-+]?(?:\d+\.\d*|\.\d+|\d+)(?:[eE][-+]?\d+)?")


#: A certified bound may exceed the recorded one by the largest raw
#: back-off (`ctrl_lpv.output_feedback.stages._RAW_BACKOFFS`): another
#: machine's raw optimum may certify at another of them.
_NO_WORSE = 5e-4


def _bound(outcome, key):
    value = outcome.get(key)
    return None if value is None else float.fromhex(value)


def _same(now, then):
    """The same decision, bounds no worse (see above)."""
    assert now["verdict"] == then["verdict"], now.get("message", "")
    if now["verdict"] != "design":
        first = [_NUMBER.sub("#", o["message"].splitlines()[0]) for o in (now, then)]
        assert first[0] == first[1]
        return
    assert sorted(now) == sorted(then)
    for key in ("gamma", "gamma_opt"):
        assert (now[key] is None) == (then[key] is None), key
    # The certified bound; not the optimum's estimate, which follows the
    # solver's path (fuzz 2026:1: 5.10 here, 5.40 recorded; hinf_of 3 raw
    # estimated on the renormalised rung).
    if now["gamma"] is not None:
        assert _bound(now, "gamma") <= _bound(then, "gamma") * (1.0 + _NO_WORSE)


@pytest.mark.parametrize(("call", "recorded"), _corpus())
def test_one_ladder_decides_as_the_two_loops_did(call, recorded):
    """The verdict of the two loops, and bounds no worse than theirs."""
    from _ladder_corpus import outcome

    _same(outcome(call), recorded)
