"""rollsim analytic: tables, plots, and what they say about the paper's Fig. 9."""

import json

import pytest

from rollsim.channel.analytic import mmbp_p_message
from rollsim.channel.tables import COLUMNS, analytic_table, ge_from_mmbp
from rollsim.cli import main


def test_table_has_every_column_and_probabilities():
    rows = analytic_table(5, 2, 1e-3, 50, range(1, 11))
    assert [row["r"] for row in rows] == list(range(1, 11))
    for row in rows:
        assert tuple(row) == COLUMNS
        assert all(0.0 <= row[c] <= 1.0 for c in COLUMNS[1:])


def test_ge_from_mmbp_is_the_papers_eq_1():
    p, q = ge_from_mmbp(5, 2)
    assert p == pytest.approx(5 / 7) and p + q == pytest.approx(1.0)


@pytest.mark.parametrize("M, N", [(5, 2), (2, 5), (4, 3)])
def test_rp_equals_rs_when_n_packets_is_one_more_than_a_multiple_of_the_cycle(M, N):
    """The paper's Fig. 9 (left) says RS reaches P(message) > 0.9 with r = 3
    while RP needs r = 6, for M = 5, N = 2, N_p = 50, and (right) that RS
    stays below 0.6 for M < 3. Its own model says otherwise: 50 = 7·7 + 1,
    so under RS the copies of a packet, 50 slots apart, fall in consecutive
    cycle slots exactly as under RP; for r coprime with 7 both strategies
    give every packet the same multiset of slot windows and the same
    P(message). rollsim reports the exact value."""
    for r in range(1, 7):
        rp = mmbp_p_message(M, N, r, 1e-3, 50, "rp")
        rs = mmbp_p_message(M, N, r, 1e-3, 50, "rs")
        assert rp == pytest.approx(rs, rel=1e-12, abs=1e-300)
    # RS with M = 2 does reach 0.98 by r = 6, not "below 0.6 even for 10".
    assert mmbp_p_message(2, 5, 6, 1e-3, 50, "rs") > 0.98


def test_cli_csv_json_and_plot(tmp_path, capsys):
    assert main(["analytic", "--r-max", "4"]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert lines[0] == ",".join(COLUMNS) and len(lines) == 5
    out = tmp_path / "t.json"
    png = tmp_path / "t.png"
    assert main(["analytic", "--M", "3", "--N", "4", "--n-packets", "21", "--json", str(out), "--plot", str(png)]) == 0
    data = json.loads(out.read_text())
    assert data["M"] == 3 and len(data["rows"]) == 10
    # 21 packets = 3 cycles of 7: under RS some packets always fall in OFF slots.
    assert all(row["mmbp_p_message_rs"] == 0.0 for row in data["rows"])
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_cli_bad_parameters_are_one_line(capsys):
    assert main(["analytic", "--p-e", "2"]) == 2
    assert capsys.readouterr().err.splitlines() == ["rollsim: error: --p-e = 2.0: must be in [0, 1]"]
    assert main(["analytic", "--p", "0.5"]) == 2
    assert len(capsys.readouterr().err.splitlines()) == 1
