"""Frames read as unbinned that were binned: a second fit in pairs of rows, kept where it matches clearly better.

JPEG's 8×8 blocks and the ISP's smoothing can hide a 2× binned readout's
pairs from the frames' rows and from the stripes' edges
(:mod:`rollsim.fit.binning`), and neither statistic then separates binned
from unbinned frames: the stripe fit's residual in pairs over its residual
in rows spans 0.89–2.05 on binned cameras of ``rollsim bench fit-camera``
(seeds 1–6) and 0.99–1.3 on unbinned ones with smoothing or JPEG. What does
separate them is the whole fit: refined in pairs, its render matches a
binned camera's stripes where the unbinned fit's cannot. So where the
unbinned fit's render misses the frames' row profiles (a correlation under
:data:`TRIAL_BELOW`, the benchmark's target) and the stripes' edges are not
far from steps of two rows (:data:`PAIRED_RATIO_MAX`), the frames are
fitted again in pairs (a second fit's time), and that fit is kept only where
three tests agree: its render's correlation with the frames is higher by
more than :data:`CORRELATION_GAIN`, its own mismatch
(:attr:`rollsim.fit.refine.CameraFit.mismatch`) is lower, and its
correlation reaches :data:`TRIAL_BELOW`, the mark the fit in rows missed:
pairs are taken for the frames' explanation only where they explain them.
Each of the first two alone picks pairs for unbinned cameras: the
correlation alone for one whose paired fit's levels are far off (a
mismatch of 5.4 against 0.005), the mismatch alone for ones whose
correlation falls. Without the third, an unbinned camera whose fit in rows
fails outright is binned because pairs fail less: recorded as video
(``rollsim bench fit-camera --seed 1 --video``, camera 12: 488×366 colour,
21 full scales), its fit in rows correlates 0.02 and in pairs 0.87, with a
lower mismatch. The binned cameras the trial finds reach 0.988–0.9991.
"""

from __future__ import annotations

from rollsim.fit.camera import FRAMES, Estimate

# The group of rows tried: the 2× vertical binning of sensors' binned
# modes (other groups are told: ``fit-camera --binning-rows``).
TRIAL_ROWS = 2
# An unbinned fit whose render correlates with the frames' row profiles at
# least this well (the least over the frames) is kept without a trial.
TRIAL_BELOW = 0.98
# No trial where the stripes' edges are far from steps of two rows: their
# fit in pairs leaves more than this times the residual of their fit in
# rows. Binned cameras of the benchmark whose pairs the frames hide give
# 0.89–2.05 (seeds 1–6); paper-default's glare at ISO 10000 gives 8.8.
PAIRED_RATIO_MAX = 2.5
# How much higher the paired fit's correlation must be. On seeds 1–6 of the
# benchmark, the paired fit of an unbinned camera whose mismatch is not far
# off gains at most 0.0023; the binned cameras it finds gain 0.018–0.065.
CORRELATION_GAIN = 0.005


def trial_due(paired_ratio: float | None, rows_found: int, height_px: int, correlation: float) -> bool:
    """Whether to fit the frames again in pairs of rows.

    Parameters
    ----------
    paired_ratio : float or None
        The stripes' fit in pairs of rows over their fit in rows (RMS
        residuals, :attr:`rollsim.fit.camera.Measured.paired_residual_ratio`);
        None where the binning was told or seen: no trial.
    rows_found : int
        The binning the fit used, rows; only an unbinned fit (1) is tried.
    height_px : int
        The frames' height, rows; pairs must divide it.
    correlation : float
        The least row-profile correlation of the fit's render with the frames.
    """
    return (paired_ratio is not None and paired_ratio <= PAIRED_RATIO_MAX and rows_found == 1
            and height_px % TRIAL_ROWS == 0 and correlation < TRIAL_BELOW)


def paired_kept(unbinned: tuple[float, float], paired: tuple[float, float]) -> tuple[bool, str]:
    """Whether the paired fit replaces the unbinned one, and why.

    Parameters
    ----------
    unbinned, paired : (float, float)
        Each fit's least row-profile correlation with the frames and its
        mismatch (:func:`rollsim.fit.refine.mismatch`).

    Returns
    -------
    (bool, str)
        True: keep the paired fit.
    """
    (corr_1, mis_1), (corr_2, mis_2) = unbinned, paired
    figures = (f"row-profile correlation {corr_2:.4f} in pairs against {corr_1:.4f} in rows, "
               f"mismatch {mis_2:.3g} against {mis_1:.3g}")
    if not (corr_2 > corr_1 + CORRELATION_GAIN and mis_2 < mis_1):
        return False, f"fitted in pairs of rows, the render does not match the frames clearly better ({figures})"
    if corr_2 < TRIAL_BELOW:
        return False, (f"fitted in pairs of rows, the render matches the frames better but still not well "
                       f"({figures}; under {TRIAL_BELOW:g})")
    return True, f"fitted in pairs of rows, the render matches the frames better ({figures})"


def found_in_pairs(rows: int, why: str) -> Estimate:
    """The ``binning_rows`` estimate of a paired fit kept: found from the frames, and how."""
    return Estimate(float(rows), None, "rows", f"rows in groups (binned readout): {why}", FRAMES)
