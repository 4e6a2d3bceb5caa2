"""Two decoders on the same frames: outcome by outcome.

``rollsim evaluate DIR --decoded A.jsonl --against B.jsonl`` scores both
files against the same truth; :func:`compare_evaluations` then lists the
counts side by side, every emission whose outcome differs, and the
PHY-SDUs one decoder receives and the other does not. This is what a
decoder author runs first: where does mine win, where does it lose.
"""

from __future__ import annotations

from rollsim.plumbing.text_tables import format_table

# Outcomes in the order the tables list them.
OUTCOME_ORDER = ("ok", "undetected_error", "corrupted", "missed", "not_visible")


def compare_evaluations(a, b, names: tuple[str, str] = ("A", "B")) -> dict:
    """Compare two evaluations of the same frames.

    Parameters
    ----------
    a, b : Evaluation
        :func:`rollsim.stages.evaluate.evaluate` of two decoders' records on the
        same truth (so the same emissions, in the same order).
    names : (str, str)
        What to call them.

    Returns
    -------
    dict
        ``names``; ``counts`` {outcome: [a, b]}; ``false_decodes`` [a, b];
        ``differ``: one ``{tx, sequence, frame, a, b}`` per emission whose
        outcomes differ; ``ok_only_a`` and ``ok_only_b``: the tx of the
        PHY-SDUs received by one only.

    Raises
    ------
    ValueError
        If the evaluations cover different emissions.
    """
    tx_a = [o["tx"] for o in a.outcomes]
    if tx_a != [o["tx"] for o in b.outcomes]:
        raise ValueError("the two evaluations cover different emissions: not the same frames")
    differ = [{"tx": x["tx"], "sequence": x["sequence"], "frame": x["frame"], "a": x["outcome"], "b": y["outcome"]}
              for x, y in zip(a.outcomes, b.outcomes) if x["outcome"] != y["outcome"]]
    counts_a, counts_b = a.summary["counts"], b.summary["counts"]
    return {
        "names": list(names),
        "counts": {name: [counts_a.get(name, 0), counts_b.get(name, 0)] for name in OUTCOME_ORDER},
        "false_decodes": [len(a.false_decodes), len(b.false_decodes)],
        "differ": differ,
        "ok_only_a": [d["tx"] for d in differ if d["a"] == "ok"],
        "ok_only_b": [d["tx"] for d in differ if d["b"] == "ok"],
    }


def format_comparison(comparison: dict, max_rows: int = 20) -> str:
    """The comparison as text: counts side by side, then the first differing outcomes."""
    a, b = comparison["names"]
    rows = [(name, *values) for name, values in comparison["counts"].items()]
    rows.append(("false decodes", *comparison["false_decodes"]))
    lines = [f"A = {a}", f"B = {b}", format_table(rows, ("outcome", "A", "B")), ""]
    differ = comparison["differ"]
    lines.append(f"{len(differ)} emissions differ: {len(comparison['ok_only_a'])} received by A only, "
                 f"{len(comparison['ok_only_b'])} by B only")
    if differ:
        shown = [(d["tx"], d["sequence"], d["frame"], d["a"], d["b"]) for d in differ[:max_rows]]
        lines.append(format_table(shown, ("tx", "sequence", "frame", "A", "B")))
        if len(differ) > max_rows:
            lines.append(f"... and {len(differ) - max_rows} more (comparison.json lists them all)")
    return "\n".join(lines)
