"""rollsim from Python, notebook style: render, decode, evaluate, fit and plot.

Run it as a script (``python examples/tour.py [--out DIR] [--frames N]``;
the plot goes to ``DIR/tour.png``, DIR a new temporary folder when not
given, never the current one) or cell by cell in a notebook. For the paper's default link at three distances it
renders frames, decodes them with rollsim's decoder, scores every PHY-SDU
against the ground truth, fits the MMBP channel model, and plots the
fraction of fully visible PHY-SDUs received and the fitted ON slots per
cycle, M / (M + N), against distance.
"""

from __future__ import annotations

import argparse
import tempfile
from pathlib import Path

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


def main(argv: list[str] | None = None) -> Path:
    """The script: the table printed, the plot written into ``--out`` (made if missing); its path."""
    parser = argparse.ArgumentParser(description="rollsim's tour: three distances, rendered, decoded, fitted")
    parser.add_argument("--out", type=Path, help="folder for tour.png (default: a new temporary folder)")
    parser.add_argument("--frames", type=int, default=30, help="frames per distance (default 30)")
    args = parser.parse_args(argv)
    out = args.out if args.out is not None else Path(tempfile.mkdtemp(prefix="rollsim-tour-"))
    out.mkdir(parents=True, exist_ok=True)
    table = tour(args.frames)
    for row in table:
        print(row)
    path = out / "tour.png"
    plot(table, str(path))
    print(f"wrote {path}")
    return path


if __name__ == "__main__":
    main()
