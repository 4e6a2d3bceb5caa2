"""The phase sweep: MMBP averages over cycles of any length in O(emissions) memory.

Checked against the dense O(C) forms (themselves checked against brute-force
enumeration in test_analytic.py) on every small case hypothesis draws, and
on cycles of 10**9 slots against closed forms.
"""

import math
import tracemalloc

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from rollsim.channel import analytic, phase_sweep
from rollsim.cli import main

P_E = st.sampled_from([0.0, 1e-9, 1e-3, 0.3, 0.9, 0.999, 1.0])


def _dense_log_message(M, N, r, p_e, n, strategy):
    return analytic._log_mean_exp(analytic._log_message_per_phase(M, M + N, r, p_e, n, strategy))


def _sweep_log_message(M, N, r, p_e, n, strategy):
    emissions = np.arange(r * n)
    packets = emissions // r if strategy == "rp" else emissions % n
    return phase_sweep.log_mean_message(M, M + N, emissions, packets, n, p_e)


@settings(max_examples=400, deadline=None)
@given(M=st.integers(0, 12), N=st.integers(0, 12), r=st.integers(1, 14), n=st.integers(1, 10), p_e=P_E,
       strategy=st.sampled_from(["rp", "rs"]))
def test_sweep_equals_dense_message_probability(M, N, r, n, p_e, strategy):
    if M + N == 0:
        return
    dense = _dense_log_message(M, N, r, p_e, n, strategy)
    sweep = _sweep_log_message(M, N, r, p_e, n, strategy)
    if math.isinf(dense) or math.isinf(sweep):
        assert dense == sweep
    else:
        assert sweep == pytest.approx(dense, abs=1e-12)


@settings(max_examples=400, deadline=None)
@given(M=st.integers(0, 12), N=st.integers(0, 12), r=st.integers(1, 30), n=st.integers(1, 10), p_e=P_E)
def test_sweep_equals_dense_loss_probability(M, N, r, n, p_e):
    if M + N == 0:
        return
    C = M + N
    rp = float(np.mean(np.power(p_e, analytic._on_counts_rp(M, C, r))))
    rs = float(np.mean(np.power(p_e, analytic._on_counts_rs(M, C, r, n))))
    # The sweep sums its C phases in log space (its terms may underflow): the
    # exponent it takes e to, about log C at most, carries a few ulp of its
    # size, so the result may be off by ~1e-15·(1 + ln C) (5 ulp of 1 was seen
    # at C = 14); 1e-15 alone failed there.
    tolerance = 1e-15 * (1.0 + math.log(C))
    assert phase_sweep.mean_loss(M, C, np.arange(r), p_e) == pytest.approx(rp, abs=tolerance)
    assert phase_sweep.mean_loss(M, C, np.arange(r) * n, p_e) == pytest.approx(rs, abs=tolerance)


def test_public_functions_switch_to_the_sweep_above_the_dense_cycle():
    # Just above the switch both methods are affordable: they must agree.
    M, N = analytic._DENSE_MAX_CYCLE // 2 + 7, analytic._DENSE_MAX_CYCLE // 2 + 3
    assert analytic._sweeps(M + N, 50)
    dense = _dense_log_message(M, N, 3, 0.01, 50, "rs")
    assert analytic.mmbp_log_p_message(M, N, 3, 0.01, 50, "rs") == pytest.approx(dense, abs=1e-12)


def test_billion_slot_cycle_matches_the_papers_eq6_in_constant_memory():
    # For r < M, N the paper's Eq. 6 is exact (see test_analytic.py).
    M = N = 10**9
    tracemalloc.start()
    values = [analytic.mmbp_p0_rp(M, N, r, 0.01) for r in (1, 2, 5, 10)]
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    expected = [analytic.paper_eq6_p0_rp(M, N, r, 0.01) for r in (1, 2, 5, 10)]
    assert values == pytest.approx(expected, rel=1e-12)
    assert peak < 1e6


def test_billion_slot_cycle_message_probability_closed_forms():
    M, N, n, p_e = 10**9, 5 * 10**8, 50, 1e-3
    # r = 1: all n consecutive slots must be ON; M - n + 1 phases of the C give that.
    expected = (M - n + 1) / (M + N) * (1 - p_e) ** n
    for strategy in ("rp", "rs"):
        assert analytic.mmbp_p_message(M, N, 1, p_e, n, strategy) == pytest.approx(expected, rel=1e-12)
    # N = 0: every slot is ON, packets are independent.
    assert analytic.mmbp_p_message(M, 0, 3, p_e, n, "rp") == pytest.approx((1 - p_e**3) ** n, rel=1e-12)


def test_cycle_that_neither_method_affords_is_refused_before_allocating(monkeypatch):
    from rollsim.errors import BudgetError

    monkeypatch.setenv("ROLLSIM_MEMORY_LIMIT", "10M")
    with pytest.raises(BudgetError, match=r"M \+ N = 2000000000 with 5000000 emissions per round"):
        analytic.mmbp_p_message(10**9, 10**9, 100_000, 1e-3, 50, "rp")


def test_analytic_command_answers_for_a_billion_slots(capsys):
    assert main(["analytic", "--M", "1000000000", "--N", "2", "--r-max", "2"]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert len(lines) == 3 and lines[1].startswith("1,")
