"""How well one emitter parameter set reproduces the paper's Fig. 11.

paper-default's LED (its luminous intensity and glare halo) was fitted to the
testbed's ROI ratio at 5-40 cm: the decoder's stripe rows over the frame's,
told the exposure as every run is (:mod:`rollsim.render.tuning`). This
module measures one candidate set the way the fit did, so the fit can be
checked or repeated::

    python -m rollsim.bench.emitter_fit 20 0.06,0.5,3,1.75 0.045,0.8,4.2,2

prints, per set (I_v in cd, η, θ₀ in degrees, β), the largest difference from
the testbed and each distance's rows with its difference.
"""

from __future__ import annotations

import sys
from dataclasses import dataclass
from typing import Sequence

import numpy as np

from rollsim.channel.channels import camcomsim_roi
from rollsim.render import RenderPipeline
from rollsim.scene import load_scene
from rollsim.sweeps.stream import DecodedRun

FIG11_DISTANCES_CM = (5, 10, 15, 20, 25, 30, 35, 40)


@dataclass(frozen=True)
class EmitterSet:
    """One candidate: the LED's luminous intensity (cd) and its glare halo (η, θ₀ in degrees, β)."""

    luminous_intensity_cd: float
    fraction: float
    core_angle_deg: float
    exponent: float

    @classmethod
    def parse(cls, text: str) -> "EmitterSet":
        """From ``"I_v,eta,theta0_deg,beta"``; a clear error names the text otherwise."""
        parts = text.split(",")
        try:
            values = [float(p) for p in parts]
        except ValueError:
            values = []
        if len(values) != 4:
            raise ValueError(f"emitter set {text!r}: expected I_v,eta,theta0_deg,beta (four numbers)")
        return cls(*values)

    def overrides(self) -> list[str]:
        """Scene overrides that put this set on paper-default."""
        return [f"led.luminous_intensity_cd={self.luminous_intensity_cd}", f"effects.glare.fraction={self.fraction}",
                f"effects.glare.core_angle_deg={self.core_angle_deg}", f"effects.glare.exponent={self.exponent}"]


def stripe_rows(emitter: EmitterSet | None, distance_cm: float, frames: int, seed: int | None = None) -> float:
    """Mean over ``frames`` frames of the decoder's stripe rows over the frame's, told the exposure.

    ``emitter`` None keeps paper-default's own. Measured as ``rollsim
    paper`` measures Fig. 11's rows (:class:`rollsim.sweeps.stream.DecodedRun`).
    """
    overrides = [f"link.distance_cm={distance_cm}", *([] if emitter is None else emitter.overrides())]
    scene = load_scene("paper-default", [*overrides, *([] if seed is None else [f"seed={seed}"])])
    run = DecodedRun(RenderPipeline(scene), measure_stripes=True)
    for index in range(frames):
        run.step(index)
    return float(np.mean(run.stripe_fractions))


def fig11_misfit(emitter: EmitterSet, frames: int, distances_cm: Sequence[float] = FIG11_DISTANCES_CM,
                 seed: int | None = None) -> tuple[float, list[float]]:
    """Largest |rows − testbed ROI| over ``distances_cm``, and each distance's rows."""
    rows = [stripe_rows(emitter, d, frames, seed) for d in distances_cm]
    misfit = max(abs(r - camcomsim_roi(d)) for r, d in zip(rows, distances_cm))
    return float(misfit), rows


def main(argv: Sequence[str] | None = None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    if len(argv) < 2 or not argv[0].isdigit() or int(argv[0]) < 1:
        print("usage: python -m rollsim.bench.emitter_fit FRAMES I_v,eta,theta0_deg,beta [...]", file=sys.stderr)
        return 2
    frames = int(argv[0])
    try:
        emitters = [EmitterSet.parse(text) for text in argv[1:]]
    except ValueError as error:
        print(f"rollsim: error: {error}", file=sys.stderr)
        return 2
    for text, emitter in zip(argv[1:], emitters):
        misfit, rows = fig11_misfit(emitter, frames)
        cells = " ".join(f"{d}cm {r:.3f} ({r - camcomsim_roi(d):+.3f})" for d, r in zip(FIG11_DISTANCES_CM, rows))
        print(f"{text}: largest difference {misfit:.3f}; {cells}", flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
