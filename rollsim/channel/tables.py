"""Tables and plots of the analytic models against the number of copies r.

The figures of the reference paper's §4.4: the probability of receiving a
whole message of N_p packets within one round, for RP and RS, under the
MMBP (exact over the cycle phase, and the independence approximation) and
under Gilbert-Elliott (Fig. 7-9).
"""

from __future__ import annotations

from typing import Optional

from rollsim.channel.analytic import (
    ge_p0_rp,
    ge_p_message,
    mmbp_p0_rp,
    mmbp_p0_rs,
    mmbp_p_message,
)

COLUMNS = (
    "r",
    "mmbp_p0_rp",
    "mmbp_p0_rs",
    "mmbp_p_message_rp",
    "mmbp_p_message_rs",
    "mmbp_p_message_rp_independent",
    "mmbp_p_message_rs_independent",
    "ge_p0_rp",
    "ge_p_message_rp",
    "ge_p_message_rs",
)


def ge_from_mmbp(M: int, N: int) -> tuple[float, float]:
    """Gilbert-Elliott (p, q) of the paper's Eq. 1 for a cycle of M ON and N OFF slots.

    p = δ_c/δ_f = M/(M+N) and q = 1 − p (the convention of
    :func:`rollsim.channel.analytic.ge_stationary`).
    """
    p = M / (M + N)
    return p, 1.0 - p


def ratio_splits(cycle: int, most: int = 6) -> list[tuple[int, int]]:
    """At most ``most`` splits ``(M, N)`` of a cycle of ``cycle`` slots, M from 1 to cycle − 1.

    Every split of a short cycle (the paper's Fig. 9 right: M + N = 7);
    evenly spaced ones of a long cycle, so that a plot of M + N = 10**9 costs
    a few curves, not a billion.
    """
    if cycle < 2:
        return []
    ms: range | list[int]
    if cycle - 1 <= most:
        ms = range(1, cycle)
    else:
        ms = sorted({round(1 + k * (cycle - 2) / (most - 1)) for k in range(most)})
    return [(m, cycle - m) for m in ms]


def analytic_table(M: int, N: int, p_e: float, n_packets: int, r_values, p: Optional[float] = None, q: Optional[float] = None) -> list[dict]:
    """One row per r of every model's p0 and P(message) (see :data:`COLUMNS`).

    Parameters
    ----------
    M, N : int
        MMBP ON and OFF slots per frame.
    p_e : float
        PHY-SDU error probability in ON slots.
    n_packets : int
        N_p, packets in the message.
    r_values : iterable of int
        Copies per packet.
    p, q : float, optional
        Gilbert-Elliott transition probabilities; default :func:`ge_from_mmbp`.
    """
    if p is None or q is None:
        p, q = ge_from_mmbp(M, N)
    rows = []
    for r in r_values:
        rows.append(
            {
                "r": int(r),
                "mmbp_p0_rp": mmbp_p0_rp(M, N, r, p_e),
                "mmbp_p0_rs": mmbp_p0_rs(M, N, r, p_e, n_packets),
                "mmbp_p_message_rp": mmbp_p_message(M, N, r, p_e, n_packets, "rp"),
                "mmbp_p_message_rs": mmbp_p_message(M, N, r, p_e, n_packets, "rs"),
                "mmbp_p_message_rp_independent": mmbp_p_message(M, N, r, p_e, n_packets, "rp", exact=False),
                "mmbp_p_message_rs_independent": mmbp_p_message(M, N, r, p_e, n_packets, "rs", exact=False),
                "ge_p0_rp": ge_p0_rp(p, q, r, p_e),
                "ge_p_message_rp": ge_p_message(p, q, r, p_e, n_packets, "rp"),
                "ge_p_message_rs": ge_p_message(p, q, r, p_e, n_packets, "rs"),
            }
        )
    return rows


def plot_analytic(rows: list[dict], M: int, N: int, p_e: float, n_packets: int, path, ratio_rows: Optional[dict] = None) -> None:
    """Save a PNG like the paper's Fig. 7-9: P(message) against r.

    Parameters
    ----------
    rows : list of dict
        From :func:`analytic_table`.
    ratio_rows : dict, optional
        ``{(M, N): rows}`` for the right panel (Fig. 9 right: M + N fixed,
        M:N varied).
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    r = [row["r"] for row in rows]
    panels = 2 if ratio_rows else 1
    fig, axes = plt.subplots(1, panels, figsize=(6.4 * panels, 4.4), squeeze=False)
    ax = axes[0, 0]
    ax.plot(r, [x["mmbp_p_message_rp"] for x in rows], "o-", label="RP, MMBP (exact)")
    ax.plot(r, [x["mmbp_p_message_rs"] for x in rows], "s-", label="RS, MMBP (exact)")
    ax.plot(r, [x["mmbp_p_message_rp_independent"] for x in rows], "o:", label="RP, MMBP (independent packets)")
    ax.plot(r, [x["mmbp_p_message_rs_independent"] for x in rows], "s:", label="RS, MMBP (independent packets)")
    ax.plot(r, [x["ge_p_message_rp"] for x in rows], "^--", label="RP, Gilbert-Elliott")
    ax.set(xlabel="copies per packet r", ylabel=f"P(all {n_packets} packets received)", ylim=(-0.02, 1.02),
           title=f"M = {M}, N = {N}, p_e = {p_e:g}")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    if ratio_rows:
        ax = axes[0, 1]
        for (m, n), sub in ratio_rows.items():
            rr = [x["r"] for x in sub]
            line = ax.plot(rr, [x["mmbp_p_message_rs"] for x in sub], "s-", label=f"RS, M:N = {m}:{n}")[0]
            ax.plot(rr, [x["mmbp_p_message_rp"] for x in sub], "o--", color=line.get_color(), label=f"RP, M:N = {m}:{n}")
        ax.set(xlabel="copies per packet r", ylabel="P(message)", ylim=(-0.02, 1.02), title=f"M + N = {M + N}, MMBP exact")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7, ncol=2)
    fig.tight_layout()
    fig.savefig(path, dpi=120, format="png")
    plt.close(fig)
