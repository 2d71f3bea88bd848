"""The two-mass drive on angle encoders: certified output feedback of the
paper's LPV model (tracking formulation), checked on frozen closed loops
built by python-control from the returned controller."""

import control as ct
import numpy as np
import pytest

from ctrl_lpv import twomass


@pytest.mark.parametrize("sensors", ["both", "motor"])
def test_encoder_designs_certify_and_bound_the_frozen_loops(sensors):
    d = twomass.output_feedback_design(sensors=sensors)
    assert d.certificate.verified
    controller = d.controller()
    measured = ["y_e_m", "y_e_l", "y_int_e_l"] if sensors == "both" else ["y_e_m"]
    assert controller.input_labels == [*measured, "p"]
    assert controller.output_labels == ["Tm"]
    sys = d.plant.system
    w = d.plant.names("w")
    z = d.plant.names("z")
    for p in np.linspace(-0.95, 0.0, 7):
        loop = ct.interconnect([sys.at({"p": p}), controller.at({"p": p})],
                               inplist=w, outlist=z)  # fmt: skip
        assert np.linalg.eigvals(loop.A).real.max() < 0
        assert float(ct.linfnorm(loop)[0]) <= d.gamma


def test_bad_sensor_set_is_named():
    with pytest.raises(ValueError, match="sensors"):
        twomass.output_feedback_design(sensors="load")
