"""rollsim.bench.emitter_fit: the Fig. 11 fit of paper-default's emitter, measured again."""

import pytest

from rollsim.bench.emitter_fit import EmitterSet, fig11_misfit, main
from rollsim.channel.channels import camcomsim_roi
from rollsim.scene import load_scene


def test_a_set_is_four_numbers_and_a_bad_one_is_named():
    assert EmitterSet.parse("0.06,0.5,3,1.75") == EmitterSet(0.06, 0.5, 3.0, 1.75)
    for text in ("0.06,0.5,3", "0.06,0.5,3,x", ""):
        with pytest.raises(ValueError, match="emitter set"):
            EmitterSet.parse(text)


def test_the_bundled_set_is_paper_defaults():
    """The overrides of paper-default's own numbers leave the scene as bundled."""
    scene = load_scene("paper-default")
    bundled = EmitterSet(scene.led.luminous_intensity_cd, scene.effects.glare.fraction,
                         scene.effects.glare.core_angle_deg, scene.effects.glare.exponent)
    assert load_scene("paper-default", bundled.overrides()) == scene


def test_misfit_is_the_largest_difference_from_the_testbed():
    bundled = EmitterSet(0.06, 0.5, 3.0, 1.75)
    misfit, rows = fig11_misfit(bundled, 1, distances_cm=(10, 40))
    assert misfit == pytest.approx(max(abs(rows[0] - camcomsim_roi(10)), abs(rows[1] - camcomsim_roi(40))))
    assert misfit < 0.05 and rows[0] > rows[1]


def test_the_command_refuses_bad_input(capsys):
    assert main(["x", "0.06,0.5,3,1.75"]) == 2
    assert main(["3", "0.06,0.5"]) == 2
    assert "emitter set '0.06,0.5'" in capsys.readouterr().err
