"""A channel model of the event simulator from a calibration: ``rollsim simulate --channel fitted``.

A calibration JSON (``rollsim calibrate --json``, or a run's
``calibration.json``) holds every fitted model. :func:`channel_from_calibration`
builds the event simulator's channel of one of them, by default the one
the held-out likelihood selected (else AIC's choice):

* ``mmbp``: the MMBP's cycle, :class:`rollsim.channel.channels.MmbpChannel`;
* ``ge``: :class:`rollsim.channel.markov.GeChannel`;
* ``position``: the slot profiles of the step function
  (:mod:`rollsim.channel.position`) as a
  :class:`rollsim.channel.periodic.PeriodicChannel`.

Each is checked against the PHY-SDU duration the simulated scene gives: a
channel fitted at another duration describes other slots.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

from rollsim.errors import RollsimError

MODELS = ("mmbp", "ge", "position")
# PHY-SDU durations within this fraction are the same duration.
DURATION_TOLERANCE = 1e-6


def read_calibration(path) -> dict:
    """The calibration JSON at ``path``; a one-line error naming the file otherwise."""
    path = Path(path)
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise RollsimError(f"{path}: does not exist") from None
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise RollsimError(f"{path}: not a calibration JSON ({exc})") from None
    if not isinstance(data, dict) or "mmbp" not in data or "ge" not in data:
        raise RollsimError(f"{path}: not a calibration JSON (no 'mmbp' and 'ge' fits); write one with rollsim calibrate --json")
    return data


def selected_model(calibration: dict) -> str:
    """The model a calibration selects: by held-out likelihood where it was scored, else by AIC."""
    return calibration.get("selected_by_heldout") or calibration["selected_by_aic"]


def channel_from_calibration(calibration: dict, sdu_duration_s: float, model: str | None = None, source: str = "calibration"):
    """The event simulator's channel of one fitted model (see the module docstring).

    Parameters
    ----------
    calibration : dict
        :func:`rollsim.calibrate.calibrate`'s result, as JSON gives it back.
    sdu_duration_s : float
        T_p of the scene simulated, seconds.
    model : {'mmbp', 'ge', 'position'}, optional
        Default: :func:`selected_model`.
    source : str
        Names the calibration in errors.

    Returns
    -------
    (ChannelModel, str)
        The channel and the model's name.
    """
    from rollsim.channel.channels import MmbpChannel
    from rollsim.channel.markov import GeChannel

    name = model or selected_model(calibration)
    if name not in MODELS:
        raise RollsimError(f"--model {name}: expected one of {', '.join(MODELS)}")
    if name == "mmbp":
        m = calibration["mmbp"]
        return MmbpChannel(m["M"], m["N"], m["p_e"], sdu_duration_s), name
    if name == "ge":
        g = calibration["ge"]
        return GeChannel(g["p"], g["q"], g["p_e"], sdu_duration_s), name
    position = calibration.get("position")
    if not position:
        raise RollsimError(f"{source}: has no position model (it needs a trace with its frames' start times, "
                           "as an evaluated run directory gives)")
    fitted_s = float(position["sdu_duration_s"])
    if not math.isclose(fitted_s, sdu_duration_s, rel_tol=DURATION_TOLERANCE):
        raise RollsimError(f"{source}: the position model was fitted to PHY-SDUs of {fitted_s * 1e3:.6g} ms; "
                           f"the scene's last {sdu_duration_s * 1e3:.6g} ms (link.clock_hz, link.payload_bits)")
    return position_channel(position), name


def position_channel(position: dict):
    """The :class:`rollsim.channel.periodic.PeriodicChannel` of a position model's JSON."""
    from rollsim.channel.periodic import PeriodicChannel
    from rollsim.channel.position import slot_profiles

    slots = slot_profiles(position["frame_period_s"], position["sdu_duration_s"], position["edges_s"],
                          position["success"])
    return PeriodicChannel(tuple(map(tuple, slots.success.tolist())), tuple(slots.weights.tolist()),
                           position["sdu_duration_s"])
