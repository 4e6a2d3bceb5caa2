"""Comparison rows: the paper's number beside rollsim's, layer by layer.

A row of ``paper.json``::

    {figure, quantity, setting, paper, rollsim_analytic, rollsim_event,
     rollsim_pixel, unit, deviation, deviation_layer, source, notes}

``deviation`` is ``(rollsim - paper) / paper`` for the most physical layer
that gives the quantity (pixel, else event, else analytic), named by
``deviation_layer``; null where the paper gives no number.
"""

from __future__ import annotations

from rollsim.paper.experiments import Claim

FIELDS = ("figure", "quantity", "setting", "paper", "rollsim_analytic", "rollsim_event", "rollsim_pixel", "unit",
          "deviation", "deviation_layer", "source", "notes")
_LAYER_ORDER = ("pixel", "event", "analytic")
_QUANTITY_KEYS = {"ROI ratio": "roi_ratio", "goodput": "goodput_bps", "throughput": "throughput_bps", "p_e": "p_e"}


def deviation(paper, values: dict) -> tuple:
    """``(relative deviation, layer)`` of the most physical layer present, or ``(None, None)``."""
    for layer in _LAYER_ORDER:
        value = values.get(layer)
        if value is not None and paper:
            return (value - paper) / paper, layer
    return None, None


def comparison_row(claim: Claim, values: dict, notes=()) -> dict:
    """One row of ``paper.json`` from a claim, ``{layer: value or None}`` and notes of this run.

    A "paper parameter" (Table 1's p_e) is an input the paper assumed, not
    a measurement: it is shown, with no deviation.
    """
    dev, layer = deviation(claim.paper, values) if claim.source != "paper parameter" else (None, None)
    return {
        "figure": claim.figure, "quantity": claim.quantity, "setting": claim.setting, "paper": claim.paper,
        "rollsim_analytic": values.get("analytic"), "rollsim_event": values.get("event"),
        "rollsim_pixel": values.get("pixel"), "unit": claim.unit, "deviation": dev, "deviation_layer": layer,
        "source": claim.source, "notes": [*claim.notes, *notes],
    }


def layer_values(claim: Claim, figures: dict) -> dict:
    """The claim's quantity from each layer's figures of its setting.

    ``figures`` maps ``"analytic"``, ``"event"`` (rollsim's mmbp channel),
    ``"camcomsim"`` and ``"pixel"`` to figure dicts (or None where not run).
    A claim of CamComSim's is compared with the camcomsim channel alone.
    """
    key = _QUANTITY_KEYS[claim.quantity]
    values = {}
    for layer in claim.layers:
        source = "camcomsim" if (layer == "event" and claim.source == "camcomsim") else layer
        found = figures.get(source)
        values[layer] = None if found is None else found.get(key)
    return values


def analytic_rows() -> list[dict]:
    """Figs. 7–9 and 12 and Eq. 7: the paper's analytic statements against rollsim's exact MMBP.

    Each row names the erratum it shows (docs/channel-models.md).
    """
    from rollsim.channel import analytic

    rows = []
    # Fig. 9: M = 5, N = 2, N_p = 50, p_e = 0.001: the smallest r with P(message) >= 0.99.
    for strategy, paper_r in (("rs", 3), ("rp", 6)):
        r = next((r for r in range(1, 41) if analytic.mmbp_p_message(5, 2, r, 0.001, 50, strategy) >= 0.99), None)
        claim = Claim("Fig. 9", f"smallest r with P(message) >= 0.99, {strategy.upper()}",
                      "M = 5, N = 2, N_p = 50, p_e = 0.001", float(paper_r), "repeats", "paper text",
                      ("analytic",), ("erratum: with 50 = 7·7 + 1 RS copies fall in consecutive slots, as RP's do",))
        rows.append(comparison_row(claim, {"analytic": None if r is None else float(r)}))
    # Fig. 12's text: under RS with N_p a multiple of M + N, P(packet received).
    p_packet = 1.0 - analytic.mmbp_p0_rs(5, 2, 6, 0.001, 49)
    claim = Claim("Fig. 12", "P(packet received), RS, bound", "M = 5, N = 2, N_p = 49, r = 6, p_e = 0.001",
                  2 / 7, "", "paper text", ("analytic",),
                  ("erratum: the text's bound N/(M+N); every copy of a packet meets the same slot, so M/(M+N)",))
    rows.append(comparison_row(claim, {"analytic": p_packet}))
    # Eq. 7 as printed against the exact p0 (N < r < M).
    claim = Claim("Eq. 7", "p0, RP", "M = 5, N = 2, r = 4, p_e = 0.1", analytic.paper_eq7_p0_rp(5, 2, 4, 0.1), "",
                  "paper formula", ("analytic",), ("erratum: exact only for r = N + 1; overestimates p0 for r >= N + 2",))
    rows.append(comparison_row(claim, {"analytic": analytic.mmbp_p0_rp(5, 2, 4, 0.1)}))
    return rows


def message_probability_rows(M: int, N: int, p_e: float, n_packets: int, r_values, event: dict) -> list[dict]:
    """Figs. 7 and 8: P(message in one round) against r, analytic (MMBP and GE) and simulated.

    ``event[(strategy, r)]`` is the simulated fraction of runs complete
    within their first round (or None).
    """
    from rollsim.channel.tables import analytic_table

    rows = []
    setting = f"M = {M}, N = {N}, N_p = {n_packets}, p_e = {p_e:g}"
    for row in analytic_table(M, N, p_e, n_packets, r_values):
        r = row["r"]
        for figure, strategy in (("Fig. 7", "rp"), ("Fig. 8", "rs")):
            claim = Claim(figure, f"P(message), {strategy.upper()}, MMBP", f"{setting}, r = {r}", None, "", "model",
                          ("analytic", "event"))
            rows.append(comparison_row(claim, {"analytic": row[f"mmbp_p_message_{strategy}"],
                                               "event": event.get((strategy, r))}))
        claim = Claim("Fig. 7", "P(message), RP, Gilbert-Elliott", f"{setting}, r = {r}", None, "", "model",
                      ("analytic",), ("p = M/(M+N), q = 1 - p (Eq. 1)",))
        rows.append(comparison_row(claim, {"analytic": row["ge_p_message_rp"]}))
    return rows
