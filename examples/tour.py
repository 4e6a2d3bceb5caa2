"""rollsim from Python, notebook style: render, decode, evaluate, fit and plot.

Run it as a script (``python examples/tour.py [OUT.png] [FRAMES]``) or cell
by cell in a notebook. For the paper's default link at three distances it
renders frames, decodes them with rollsim's decoder, scores every PHY-SDU
against the ground truth, fits the MMBP channel model, and plots the
fraction of fully visible PHY-SDUs received and the fitted ON slots per
cycle, M / (M + N), against distance.
"""

from __future__ import annotations

import sys

import matplotlib

matplotlib.use("Agg")  # a script writes a file; a notebook shows the figure
import matplotlib.pyplot as plt  # noqa: E402

import rollsim as rs  # noqa: E402

DISTANCES_CM = (5, 10, 20)


def tour(n_frames: int = 30) -> list[dict]:
    """One row per distance: counts, fitted M, N and p_e."""
    rows = []
    for distance_cm in DISTANCES_CM:
        scene = rs.load_scene("paper-default", overrides={"link.distance_cm": distance_cm})
        frames = rs.render(scene, n_frames=n_frames, seed=1)
        result = rs.evaluate(frames.truth, rs.decode(frames))
        fit = rs.calibrate(result)
        fully = result.summary["fully_visible"]
        # Among the fully visible PHY-SDUs: the decoder also reads some that
        # the truth's readable rows leave partly out.
        ok = result.summary["fully_visible_counts"]["ok"]
        rows.append({"distance_cm": distance_cm, "ok": ok, "fully_visible": fully,
                     "ok_fraction": ok / fully if fully else 0.0,
                     "M": fit.mmbp.M, "N": fit.mmbp.N, "p_e": fit.mmbp.p_e})
    return rows


def plot(rows: list[dict], path: str) -> None:
    """Received fraction and M / (M + N) against distance, written to ``path``."""
    distance = [r["distance_cm"] for r in rows]
    fig, ax = plt.subplots(figsize=(5, 3.2))
    ax.plot(distance, [r["ok_fraction"] for r in rows], "o-", label="ok / fully visible")
    ax.plot(distance, [r["M"] / (r["M"] + r["N"]) for r in rows], "s--", label="fitted M / (M + N)")
    ax.set_xlabel("distance (cm)")
    ax.set_ylim(0, 1.05)
    ax.legend()
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)


if __name__ == "__main__":
    out = sys.argv[1] if len(sys.argv) > 1 else "tour.png"
    table = tour(int(sys.argv[2]) if len(sys.argv) > 2 else 30)
    for row in table:
        print(row)
    plot(table, out)
    print(f"wrote {out}")
