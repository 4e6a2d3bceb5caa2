"""rollsim.fit.camera.exposure_choices: the exposures the stripes allow, and the alternatives a fit reports.

Whole stripe periods of exposure more, and the reflection E <-> P - E, make
the same stripes with other ON and OFF levels; a fit picks one by the OFF
level (or by rendering the likeliest, where one renders plainly nearer the
frames) and names the others (``alternatives`` in fit.json), so that a user
who knows the camera's setting can tell which is right.
"""

from types import SimpleNamespace

import numpy as np
import pytest

from rollsim.fit.camera import FRAMES, MIN_OFF_LEVEL, Estimate, NoiseFit, Parameters, StripeTerms, corrected, \
    exposure_alternatives_rows, exposure_choices
from rollsim.fit.report import alternatives_lines
from rollsim.fit.stripes import levels_for_whole_periods, reflected_levels, square_wave_box
from rollsim.scene import load_scene

PERIOD = 20.0


def _measured(exposure_rows, on, off, background=None):
    stripes = SimpleNamespace(exposure_rows=exposure_rows, on=on, off=off, gamma=1.0)
    return SimpleNamespace(stripes=stripes, stripes_period_rows=PERIOD, background=background)


def _levels(choice, rows, phase):
    return choice.off + (choice.on - choice.off) * square_wave_box(rows, PERIOD, phase, choice.exposure_rows)


@pytest.mark.parametrize("exposure, on, off", [(3.7, 0.6, 0.3), (12.0, 0.9, 0.5), (6.0, 0.3, 0.02)])
def test_every_choice_makes_the_same_stripes_and_no_negative_light(exposure, on, off):
    base = load_scene("paper-geometric", [])
    choices = exposure_choices(_measured(exposure, on, off), base)
    rows = np.arange(0.0, 200.0)
    fitted = [c for c in choices if not c.reflected and c.whole_periods == 0]
    assert fitted and fitted[0].exposure_rows == pytest.approx(exposure)
    first = _levels(fitted[0], rows, 3.0)
    for c in choices:
        assert c.off >= MIN_OFF_LEVEL
        if c.off_at_face:
            continue  # moved within its branch: test_a_choice_of_negative_light_is_moved_to_the_faces_off_level
        # The same stripes: directly, or half a period on (the reflection), at some phase.
        phases = np.linspace(0.0, PERIOD, 401)
        best = min(np.max(np.abs(_levels(c, rows, p) - first)) for p in phases)
        assert best < 1e-9 or c.reflected, (c, best)
        if c.reflected:
            assert best < 0.01 * (on - off), (c, best)


def test_the_choices_are_ordered_by_the_off_level_nearest_the_face():
    # Without a background the face is taken as dark (the OFF level nearest 0 comes first), but its
    # light is not measured: the choices below zero are left out.
    base = load_scene("paper-geometric", [])
    unmeasured = exposure_choices(_measured(12.0, 0.9, 0.5), base)
    assert sorted(round(c.exposure_rows, 9) for c in unmeasured) == [8.0, 12.0, 28.0, 32.0]
    assert not any(c.off_at_face for c in unmeasured)
    # A black background: the face is measured dark.
    choices = exposure_choices(_measured(12.0, 0.9, 0.5, background=0.0), base)
    # E = 12 rows of P = 20 and its reflection 8, each with one more period (OFF lower by 1/3 each).
    kept = [c for c in choices if not c.off_at_face]
    assert sorted(round(c.exposure_rows, 9) for c in kept) == [8.0, 12.0, 28.0, 32.0]
    offs = [abs(c.off) for c in kept]
    assert offs == sorted(offs)
    # Two periods more would need OFF levels of -0.1 (reflected) and -1/6: each is moved within
    # its branch to an OFF level of 0 (the profile spans 0.5667 … 0.8333, rho = 0.68), and keeps
    # its place: 49.41 rows (2 periods and 0.941 chips) first, 50.4 (2 periods and 1.04 chips) next.
    moved = [c for c in choices if c.off_at_face]
    assert [round(c.exposure_rows, 2) for c in moved] == [49.41, 50.4]
    assert choices.index(moved[0]) == 0 and choices.index(moved[1]) in (1, 2)


def test_alternatives_follow_the_refined_exposure():
    base = load_scene("paper-geometric", [])
    choices = exposure_choices(_measured(12.0, 0.9, 0.5), base)
    first = choices[0]
    # The refinement moved the chosen exposure by half a row: the others move with it
    # (a reflected choice the other way).
    refined = first.exposure_rows + 0.5
    alternatives = exposure_alternatives_rows(refined, PERIOD, choices)
    within = refined - first.whole_periods * PERIOD
    e0 = PERIOD - within if first.reflected else within
    expected = sorted({round((PERIOD - e0 if c.reflected else e0) + c.whole_periods * PERIOD, 9)
                       for c in choices[1:]} - {round(refined, 9)})
    assert alternatives == pytest.approx(expected)
    for e in alternatives:
        # Each is the refined exposure up to whole periods, or its reflection.
        k = (e - refined) / PERIOD
        r = (e + refined) / PERIOD
        assert abs(k - round(k)) < 1e-9 or abs(r - round(r)) < 1e-9


def test_the_report_names_the_alternatives():
    estimates = {"exposure_us": Estimate(140.0, 3.0, "us", "box", alternatives=(497.0, 777.0)),
                 "iso": Estimate(400.0, None, "", "gain")}
    text = "\n".join(alternatives_lines(estimates))
    assert "497, 777 us" in text and "iso" not in text
    assert Estimate(140.0, 3.0, "us", "box", alternatives=(497.0,)).to_json()["alternatives"] == [497.0]
    assert "alternatives" not in estimates["iso"].to_json()


@pytest.mark.parametrize("mismatches, kept", [
    ([0.5], 0),                  # one choice: nothing to choose
    ([7.8, 0.012, 0.016], 1),    # the OFF level's first renders plainly wrong: the nearest is kept
    ([0.03, 0.013, 0.0023], 0),  # 14 times nearer, but by less than two renders of one scene differ
    ([0.5, 0.2, 0.3], 0),        # nearer by 0.3, but not by a factor of four
    ([0.2, 0.5, 0.9], 0),        # the first is the nearest
])
def test_a_rendered_choice_replaces_the_first_only_by_a_clear_margin(mismatches, kept):
    """rollsim.fit.refine.rendered_choice: the choices' renders decide only where one fails plainly."""
    from rollsim.fit.refine import RENDERED_GAIN, RENDERED_MARGIN, rendered_choice

    assert rendered_choice(mismatches) == kept
    if kept:
        assert mismatches[0] > RENDERED_MARGIN * mismatches[kept]
        assert mismatches[0] - mismatches[kept] > RENDERED_GAIN


def test_a_choice_of_negative_light_is_moved_to_the_faces_off_level():
    # The truth: P = 20 rows, E = 17 (1.7 chips), ON 1, OFF 0 (a dark face): the profile spans
    # 0.7/1.7 … 1/1.7. The stripe fit traded a row of exposure for smoothing and read the
    # reflection as 2 rows, not 3, with the same extremes (E = 2 < P/2: OFF and ON are them).
    # Its reflection, 18 rows, would need an OFF level of -0.29: moved within its branch (no
    # whole period, the upper half) to OFF 0 (a black background measures the face dark), it is
    # the truth, exactly, and comes first.
    from rollsim.fit.stripes import profile_extremes

    base = load_scene("paper-geometric", [])
    y_min, y_max = 0.7 / 1.7, 1.0 / 1.7
    choices = exposure_choices(_measured(2.0, y_max, y_min, background=0.0), base)
    first = choices[0]
    assert first.off_at_face and first.reflected and first.whole_periods == 0
    assert (first.exposure_rows, first.on, first.off) == (pytest.approx(17.0), pytest.approx(1.0), 0.0)
    for c in choices:
        if c.off_at_face:
            assert c.off == 0.0
            assert profile_extremes(c.exposure_rows, c.on, c.off, PERIOD) == (pytest.approx(y_min), pytest.approx(y_max))
            within = c.exposure_rows - c.whole_periods * PERIOD
            assert 0 < within < PERIOD


@pytest.mark.parametrize("whole", [0, 1, 2, 3])
@pytest.mark.parametrize("chips", [0.2, 0.7, 1.0, 1.3, 1.9])
def test_the_exposure_for_an_off_level_inverts_the_box(whole, chips):
    # A box of 2k + r chips on levels ON, OFF spans known extremes; given them and OFF, the
    # exposure of its branch comes back.
    from rollsim.fit.stripes import exposure_for_off_level, profile_extremes

    exposure = (2 * whole + chips) * PERIOD / 2
    on, off = 0.8, 0.05
    y_min, y_max = profile_extremes(exposure, on, off, PERIOD)
    upper = chips >= 1.0
    found = exposure_for_off_level(y_min, y_max, off, PERIOD, whole, upper)
    if whole == 0 and not upper:
        assert found is None  # OFF is the profile's least level there: every such box makes it
    else:
        assert found == (pytest.approx(exposure), pytest.approx(on))
    assert exposure_for_off_level(y_min, y_max, y_min + 0.01, PERIOD, whole, upper) is None  # OFF above the least



@pytest.mark.parametrize("exposure", [3.7, 12.0, 19.999, 27.5, 36.0, 61.0])
@pytest.mark.parametrize("like", [2.0, 10.0, 17.0])
def test_stripe_terms_make_the_same_stripes_and_map_back(exposure, like):
    on, off = 0.7, 0.05
    terms = StripeTerms.of(exposure, on, off, PERIOD, like)
    assert 0.0 < terms.exposure_rows <= PERIOD
    assert terms.exposure_and_levels(PERIOD) == pytest.approx((exposure, on, off), rel=1e-12, abs=1e-12)
    # Of the two charts (E0 and P - E0), the one nearer the frames' fit.
    assert abs(terms.exposure_rows - like) <= abs(PERIOD - terms.exposure_rows - like) + 1e-12
    rows = np.arange(0.0, 200.0)
    fitted = _levels(SimpleNamespace(exposure_rows=exposure, on=on, off=off), rows, 3.0)
    phases = np.linspace(0.0, PERIOD, 801)
    best = min(np.max(np.abs(_levels(terms, rows, p) - fitted)) for p in phases)
    assert best < 1e-9


def _target(exposure_rows, on, off):
    stripes = SimpleNamespace(exposure_rows=exposure_rows, on=on, off=off, smoothing_rows=0.8, gamma=1.0)
    return SimpleNamespace(stripes=stripes, stripes_period_rows=PERIOD, noise_levels=np.array([]),
                           noise_variances=np.array([]), background=None, background_noise=None, row_noise=None,
                           column_pattern=None)


@pytest.mark.parametrize("whole", [0, 1, 2])
@pytest.mark.parametrize("render_reads_reflected", [False, True])
def test_a_correction_moves_the_exposure_within_its_branch(whole, render_reads_reflected):
    """A reflected choice of k whole periods more (E = kP + P - E0) is longer
    where the stripes read a shorter E0: a render that reads 0.3 rows less
    than the frames moves it 0.3 rows down, in whichever chart the render's
    fit reads it; a render that reads the frames' stripes moves nothing."""
    e0, on0, off0 = 6.5, 0.5, 0.45  # no negative light in any branch
    exposure, on, off = levels_for_whole_periods(*reflected_levels(e0, on0, off0, PERIOD), PERIOD, whole)
    p = Parameters(float(exposure), 0.8, 1.0, float(on), float(off), 1e-3, 1e-3, None, None)
    noise = NoiseFit(1e-3, 1e-3, FRAMES, FRAMES, None)
    target = _target(e0, on0, off0)
    for read_rows, moved_rows in ((e0, 0.0), (e0 - 0.3, -0.3)):
        read = (read_rows, on0, off0)
        if render_reads_reflected:
            read = reflected_levels(*read, PERIOD)
        out = corrected(p, noise, target, _target(*map(float, read)))
        assert out.exposure_rows == pytest.approx(p.exposure_rows + moved_rows, abs=1e-9)
        if moved_rows == 0.0:
            assert (out.on_lin, out.off_lin) == pytest.approx((p.on_lin, p.off_lin), rel=1e-9)


def test_levels_out_of_every_choices_reach_leave_the_fewest_whole_periods_first():
    # A saturated LED's stripe fit near the clip: ON 1.02, OFF 0.98 (E = 12 rows of P = 20).
    # Each period more lowers the OFF level by 0.04 * 20 / 24 = 1/30; four more still leave it at
    # 0.85, far above the black background's face. The levels point past every choice and tell
    # nothing of the whole periods: the stripes' own exposure comes first, not the most periods.
    from rollsim.fit.camera import off_step_per_period

    base = load_scene("paper-geometric", [])
    assert off_step_per_period(12.0, 1.02, 0.98, PERIOD) == pytest.approx(1.0 / 30.0)
    choices = exposure_choices(_measured(12.0, 1.02, 0.98, background=0.0), base)
    assert (choices[0].whole_periods, choices[0].reflected) == (0, False)
    assert choices[0].exposure_rows == pytest.approx(12.0)
    ks = [c.whole_periods for c in choices]
    assert ks == sorted(ks)
    # Within reach (a dark OFF level a period's step from the face), the OFF level alone orders them.
    near = exposure_choices(_measured(12.0, 0.9, 0.5, background=0.0), base)
    assert near[0].whole_periods > 0


def _refined(exposure_rows, on, off):
    return Parameters(exposure_rows=exposure_rows, smoothing_rows=0.0, gamma=1.0, on_lin=on, off_lin=off,
                      k_lin=1e-4, read_lin=1e-3, row_lin=None, col_lin=None)


def test_refined_levels_move_the_fit_to_the_branch_whose_off_level_is_the_faces():
    # The truth: P = 20 rows, E = 17, ON 1, OFF 0 (a dark face, a black background). The fit was
    # refined in the reflected branch, E = 3, with the levels that make the same stripes there
    # (OFF 7/17 = 0.41, far above the face). Mapped to every branch, they put OFF = 0 at 17.
    from rollsim.fit.camera import branches_by_refined_levels

    base = load_scene("paper-geometric", [])
    e, on, off = reflected_levels(17.0, 1.0, 0.0, PERIOD)
    assert e == pytest.approx(3.0) and off > 0.3
    ranked = branches_by_refined_levels(_refined(float(e), float(on), float(off)), _measured(3.0, on, off, 0.0), base)
    assert ranked is not None
    assert ranked[0].exposure_rows == pytest.approx(17.0)
    assert (ranked[0].on, ranked[0].off) == (pytest.approx(1.0), pytest.approx(0.0, abs=1e-12))
    # Refined in the right branch already: nothing to move.
    assert branches_by_refined_levels(_refined(17.0, 1.0, 0.0), _measured(3.0, on, off, 0.0), base) is None
    # Refined a whole period too long (37 rows, OFF -0.56): the branch at 17 rows holds OFF 0.02.
    e2, on2, off2 = levels_for_whole_periods(17.0, 1.0, 0.02, PERIOD, 1)
    ranked = branches_by_refined_levels(_refined(float(e2), float(on2), float(off2)), _measured(3.0, on, off, 0.0),
                                        base)
    assert ranked is not None and ranked[0].exposure_rows == pytest.approx(17.0)


def test_refined_levels_out_of_reach_or_unmeasured_face_keep_the_branch():
    from rollsim.fit.camera import branches_by_refined_levels

    base = load_scene("paper-geometric", [])
    # Saturated-looking levels (ON 1.02, OFF 0.98 at 12 rows): every branch's OFF level lies
    # many periods' steps above the black background's face; nothing to move to.
    assert branches_by_refined_levels(_refined(12.0, 1.02, 0.98), _measured(12.0, 1.02, 0.98, 0.0), base) is None
    # Refined at 17 rows with OFF 0.15: the branch at 23 rows (the reflection, a period on)
    # makes the same stripes with OFF -0.026. With a black background the face is measured
    # dark, and that is the fit's error: 23 rows is the nearest. Without a background the face
    # is only assumed dark, and a branch below zero is not a choice: the fit keeps its own.
    refined = _refined(17.0, 1.15, 0.15)
    ranked = branches_by_refined_levels(refined, _measured(3.0, 1.0, 0.0, 0.0), base)
    assert ranked is not None and ranked[0].exposure_rows == pytest.approx(23.0)
    assert MIN_OFF_LEVEL > ranked[0].off > -0.03
    assert len(ranked) > 1 and all(c.off >= MIN_OFF_LEVEL for c in ranked[1:])  # the alternatives
    assert branches_by_refined_levels(refined, _measured(3.0, 1.0, 0.0), base) is None
