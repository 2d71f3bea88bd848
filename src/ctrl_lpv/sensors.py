"""Sensor models for sampled-data simulation (`ctrl_lpv.sampled_response`).

A sensor is any callable ``sensor(value, rng) -> measured`` applied to one
plant output at each sampling instant; ``rng`` is the simulation's
`numpy.random.Generator`, so that a seed reproduces the noise. `Encoder`
models an incremental position encoder, `Quantizer` any uniform quantizer,
`Noise` additive Gaussian noise; `chain` applies several in turn.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ._checks import real_number

__all__ = ["Encoder", "Quantizer", "Noise", "chain"]


@dataclass(frozen=True)
class Quantizer:
    """Round a signal to a multiple of `step` (plus optional noise).

    Parameters
    ----------
    step : float
        Quantization step (resolution), positive.
    noise : float, optional
        Standard deviation of Gaussian noise added before rounding, in
        steps (default 0). Noise before the quantizer models the jitter of
        an edge between two counts, so that the reading flickers between
        neighbouring counts rather than drifting off the grid.
    """

    step: float
    noise: float = 0.0

    def __post_init__(self):
        real_number(self.step, "step", positive=True)
        real_number(self.noise, "noise", minimum=0.0)

    def __call__(self, value, rng):
        counts = value / self.step
        if self.noise:
            counts = counts + self.noise * rng.standard_normal()
        # Round to the nearest count: an encoder read at the centre of its
        # count (the usual half-count offset of an incremental encoder is a
        # constant that homing removes).
        return self.step * np.round(counts)


def Encoder(counts: int, noise: float = 0.0) -> Quantizer:
    """An angle encoder with `counts` counts per revolution.

    Parameters
    ----------
    counts : int
        Counts per revolution (for example ``2**20`` for a 20-bit encoder);
        the resolution is ``2 pi / counts`` rad.
    noise : float, optional
        Standard deviation of the reading's noise in counts (default 0).

    Returns
    -------
    `Quantizer`
        With ``step = 2 pi / counts``.
    """
    if isinstance(counts, bool) or not isinstance(counts, (int, np.integer)):
        raise TypeError(f"counts: expected an integer, got {counts!r}")
    if counts < 1:
        raise ValueError(f"counts: expected a positive integer, got {counts}")
    return Quantizer(2.0 * math.pi / int(counts), noise)


@dataclass(frozen=True)
class Noise:
    """Additive Gaussian noise.

    Parameters
    ----------
    std : float
        Standard deviation, in the signal's units (``>= 0``).
    """

    std: float

    def __post_init__(self):
        real_number(self.std, "std", minimum=0.0)

    def __call__(self, value, rng):
        return value + self.std * rng.standard_normal()


def chain(*sensors):
    """A sensor that applies `sensors` in the order given."""
    for i, s in enumerate(sensors):
        if not callable(s):
            raise TypeError(f"sensors[{i}]: expected a callable, got {s!r}")

    def measured(value, rng):
        for s in sensors:
            value = s(value, rng)
        return value

    return measured
