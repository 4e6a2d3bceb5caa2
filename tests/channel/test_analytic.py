"""Tests of rollsim.channel.analytic against deliberately naive enumeration.

Every reference below lists slots and packets explicitly, with no closed form
and no periodicity trick, so that it can be trusted by reading it.
"""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from rollsim.channel import analytic as an

# Stricter than the project's error::RuntimeWarning: any warning is a failure.
pytestmark = pytest.mark.filterwarnings("error")

P_ES = [0.0, 1e-9, 1e-3, 0.3, 1.0]
CYCLES = [(M, N) for M in range(9) for N in range(9) if M + N >= 1]
SMALL_CYCLES = [(M, N) for M in (0, 1, 2, 3, 5, 8) for N in (0, 1, 2, 3, 5, 8) if M + N >= 1]


# ----------------------------------------------------------------------------
# Naive references
# ----------------------------------------------------------------------------
def naive_fail(p_e, M, C, slots):
    """Probability that emissions in all ``slots`` are lost (product, no powers)."""
    prob = 1.0
    for slot in slots:
        if slot % C < M:
            prob *= p_e
    return prob


def naive_p0_rp(M, N, r, p_e):
    C = M + N
    return sum(naive_fail(p_e, M, C, [s + j for j in range(r)]) for s in range(C)) / C


def naive_p0_rs(M, N, r, p_e, n):
    C = M + N
    return sum(naive_fail(p_e, M, C, [s + j * n for j in range(r)]) for s in range(C)) / C


def packet_emissions(k, r, n, strategy):
    """Emission indices of packet ``k`` within one round."""
    if strategy == "rp":
        return [k * r + i for i in range(r)]
    return [k + j * n for j in range(r)]


def naive_p_message(M, N, r, p_e, n, strategy):
    C = M + N
    total = 0.0
    for s in range(C):
        prob = 1.0
        for k in range(n):
            slots = [s + e for e in packet_emissions(k, r, n, strategy)]
            prob *= 1.0 - naive_fail(p_e, M, C, slots)
        total += prob
    return total / C


def naive_packet_of(t, r, n, strategy):
    return (t % (r * n)) // r if strategy == "rp" else t % n


def naive_expected_emissions(M, N, r, p_e, n, strategy):
    """sum_t P(T > t), phase by phase, emission by emission."""
    C = M + N
    horizon = 2 * r * n * C  # covers a whole (packet, slot) hyperperiod
    total = 0.0
    for s in range(C):
        hits = [0] * n
        t = 0
        while True:
            done = 1.0
            for m in hits:
                done *= 1.0 - (p_e**m if m else 1.0)
            survival = 1.0 - done
            if t >= horizon and 0 in hits:
                return math.inf
            if t >= horizon and survival < 1e-18:
                break
            total += survival
            if (s + t) % C < M:
                hits[naive_packet_of(t, r, n, strategy)] += 1
            t += 1
    return total / C


def ge_paths(p, q, length):
    """All state paths (0 = S1, 1 = S2) with their stationary-start probability."""
    pi = [p / (p + q), q / (p + q)]
    P = [[1 - q, q], [p, 1 - p]]
    for path in itertools.product((0, 1), repeat=length):
        prob = pi[path[0]]
        for a, b in zip(path, path[1:]):
            prob *= P[a][b]
        yield path, prob


def naive_ge_p0(p, q, r, p_e):
    return sum(prob * math.prod(p_e if x == 0 else 1.0 for x in path) for path, prob in ge_paths(p, q, r))


def naive_ge_p_message(p, q, r, p_e, n, strategy):
    total = 0.0
    for path, prob in ge_paths(p, q, r * n):
        ok = 1.0
        for k in range(n):
            lost = math.prod(p_e if path[e] == 0 else 1.0 for e in packet_emissions(k, r, n, strategy))
            ok *= 1.0 - lost
        total += prob * ok
    return total


def corrected_eq7(M, N, r, p_e):
    """What Eq. 7 should read, for N + 1 <= r <= M + 1 (derived by counting windows).

    M-r+1 windows wholly ON (m = r); N windows start ON and end in the gap
    (m = r-N .. r-1); r-N-1 windows start ON, cross the whole gap and end ON
    (m = r - N); N windows start in the gap (m = r-N .. r-1).
    """
    C = M + N
    gap = sum(p_e**m for m in range(r - N, r))
    return ((M - r + 1) * p_e**r + 2 * gap + (r - N - 1) * p_e ** (r - N)) / C


def close(a, b, rel=1e-11, abs_=1e-14):
    return math.isclose(a, b, rel_tol=rel, abs_tol=abs_)


# ----------------------------------------------------------------------------
# Eq. 4, 5, 8: per-packet loss
# ----------------------------------------------------------------------------
@pytest.mark.parametrize("p_e", P_ES)
def test_p0_rp_matches_enumeration(p_e):
    for (M, N), r in itertools.product(CYCLES, range(1, 13)):
        got, want = an.mmbp_p0_rp(M, N, r, p_e), naive_p0_rp(M, N, r, p_e)
        assert close(got, want), (M, N, r, p_e, got, want)


@pytest.mark.parametrize("p_e", P_ES)
def test_p0_rs_matches_enumeration(p_e):
    for (M, N), r, n in itertools.product(CYCLES, (1, 2, 3, 5, 12), (1, 2, 3, 4, 6, 7, 9, 15)):
        got, want = an.mmbp_p0_rs(M, N, r, p_e, n), naive_p0_rs(M, N, r, p_e, n)
        assert close(got, want), (M, N, r, n, p_e, got, want)


def test_p0_huge_r_and_spacing_is_exact_and_finite():
    # r = 1e6 consecutive copies: every window holds >= 1 ON slot unless M = 0.
    assert an.mmbp_p0_rp(5, 2, 1e6, 0.3) == 0.0
    assert an.mmbp_p0_rp(0, 7, 10**6, 0.3) == 1.0
    assert an.mmbp_p0_rp(5, 2, 10**6, 1.0) == 1.0
    # A window of r slots holds r // C * M + (partial) ON slots: check a value
    # that does not underflow, p_e close to 1.
    p_e, r = 1 - 1e-6, 10**6 + 3
    m = np.array([r // 7 * 5 + sum((s + j) % 7 < 5 for j in range(r % 7)) for s in range(7)])
    assert close(an.mmbp_p0_rp(5, 2, r, p_e), float(np.mean(p_e**m)), rel=1e-12)
    # RS with 1e9 copies spaced 1e9 slots apart (1e9 = 6 mod 7: the walk
    # visits every slot), and spaced 7e8 apart (always the same slot).
    assert an.mmbp_p0_rs(5, 2, 10**9, 0.5, 10**9) == 0.0
    assert close(an.mmbp_p0_rs(5, 2, 10**9, 0.5, 7 * 10**8), 2 / 7)


def test_p0_rs_fig12_bound_is_M_over_C_not_N_over_C():
    # Paper §6.1: when N_p is a multiple of C, all copies of a packet land in
    # the same slot. The text says the packet reception probability is then
    # at most N/(M+N); counting gives M/(M+N) (the ON fraction), times
    # (1 - p_e^r). With M = 5, N = 2 (the paper's values) that is 5/7, not
    # the "less than 30%" (= 2/7) of the text.
    for r in (1, 3, 10, 1000):
        received = 1 - an.mmbp_p0_rs(5, 2, r, 1e-3, 49)
        assert close(received, 5 / 7 * (1 - 1e-3**r))
        assert not close(received, 2 / 7, rel=1e-3)


# ----------------------------------------------------------------------------
# The paper's Eq. 6 and Eq. 7 (claims, tested against enumeration)
# ----------------------------------------------------------------------------
@pytest.mark.parametrize("p_e", P_ES)
def test_paper_eq6_matches_enumeration_on_its_domain(p_e):
    checked = 0
    for (M, N), r in itertools.product(CYCLES, range(1, 13)):
        if r < M and r < N:
            want = naive_p0_rp(M, N, r, p_e)
            assert close(an.paper_eq6_p0_rp(M, N, r, p_e, line=2), want)
            assert close(an.paper_eq6_p0_rp(M, N, r, p_e, line=3), want)
            checked += 1
    assert checked > 50


@pytest.mark.parametrize("p_e", P_ES)
def test_paper_eq6_holds_beyond_its_stated_domain_up_to_min_plus_one(p_e):
    # Counting windows shows Eq. 6 needs only r <= M + 1 and r <= N + 1: at
    # r = M + 1 the "all ON" term vanishes, at r = N + 1 the "all OFF" one.
    for (M, N) in CYCLES:
        for r in range(1, min(M, N) + 2):
            got = an.paper_eq6_p0_rp(M, N, r, p_e, strict_domain=False)
            assert close(got, naive_p0_rp(M, N, r, p_e)), (M, N, r)


def test_paper_eq6_fails_when_window_exceeds_min_plus_one():
    # Past r = min(M, N) + 1 a count like N - r + 1 goes negative.
    M, N, r, p_e = 3, 3, 5, 0.3
    assert not close(an.paper_eq6_p0_rp(M, N, r, p_e, strict_domain=False), naive_p0_rp(M, N, r, p_e), rel=1e-3)


@pytest.mark.parametrize("p_e", P_ES)
def test_paper_eq7_exact_only_at_r_equal_N_plus_1(p_e):
    for (M, N) in CYCLES:
        r = N + 1
        if N < r < M:
            want = naive_p0_rp(M, N, r, p_e)
            assert close(an.paper_eq7_p0_rp(M, N, r, p_e, line=2), want)
            assert close(an.paper_eq7_p0_rp(M, N, r, p_e, line=3), want)


@pytest.mark.parametrize("p_e", [1e-3, 0.3, 0.9])
def test_paper_eq7_wrong_when_window_spans_gap(p_e):
    # Eq. 7, lines 2-3, term (1/C) sum_{i=1}^{r-1} p_e^i: it gives the
    # windows that start in ON slot M-i (i = 1..r-1) i ON slots. For
    # i <= r - N - 1 the window runs through the whole gap and back into ON
    # slots at the start of the next frame, so it holds i + (r - N - i) =
    # r - N ON slots: the exponent is max(i, r - N), not i. Eq. 7 therefore
    # overestimates p0 whenever r >= N + 2.
    wrong = 0
    for (M, N) in CYCLES:
        for r in range(N + 2, M):
            want = naive_p0_rp(M, N, r, p_e)
            printed = an.paper_eq7_p0_rp(M, N, r, p_e, line=2)
            assert printed > want * (1 + 1e-9), (M, N, r)
            assert close(an.paper_eq7_p0_rp(M, N, r, p_e, line=3), printed)
            excess = sum(p_e**i - p_e ** (r - N) for i in range(1, r - N)) / (M + N)
            assert close(printed - want, excess, rel=1e-9), (M, N, r)
            assert close(corrected_eq7(M, N, r, p_e), want), (M, N, r)
            wrong += 1
    assert wrong > 10


@pytest.mark.parametrize("p_e", P_ES)
def test_corrected_eq7_matches_enumeration(p_e):
    # The corrected closed form (see corrected_eq7) holds for N+1 <= r <= M+1.
    for (M, N) in CYCLES:
        for r in range(N + 1, M + 2):
            assert close(corrected_eq7(M, N, r, p_e), naive_p0_rp(M, N, r, p_e)), (M, N, r)


@pytest.mark.parametrize("p_e", [1e-3, 0.3, 0.9, 1.0])
def test_paper_eq7_last_line_drops_a_term(p_e):
    # Eq. 7, line 3 -> line 4 rewrites (1/C) sum_{i=1}^{N} p_e^(r-i) as
    # (1/C) p_e^(r-N) (p_e - p_e^N)/(1 - p_e). The correct geometric sum is
    # p_e^(r-N) (1 - p_e^N)/(1 - p_e): the printed one drops the i = N term,
    # p_e^(r-N). So line 4 disagrees even with line 3, also at r = N + 1.
    for (M, N) in CYCLES:
        for r in range(N + 1, M):
            line3 = an.paper_eq7_p0_rp(M, N, r, p_e, line=3)
            line4 = an.paper_eq7_p0_rp(M, N, r, p_e, line=4)
            assert close(line3 - line4, p_e ** (r - N) / (M + N), rel=1e-9), (M, N, r)
    # At p_e = 1 every copy is lost, p0 must be 1; line 4 gives (C - 1)/C.
    assert close(an.paper_eq7_p0_rp(8, 2, 4, 1.0, line=4), 9 / 10)
    assert close(an.paper_eq7_p0_rp(8, 2, 4, 1.0, line=3), 1.0)


def test_paper_forms_have_finite_p_e_to_1_limit():
    # (p_e - p_e^r)/(1 - p_e) -> r - 1; no division by zero at p_e = 1, and
    # the limit is continuous.
    for fn, args in ((an.paper_eq6_p0_rp, (6, 5, 4)), (an.paper_eq7_p0_rp, (8, 2, 3))):
        at_one = fn(*args, 1.0)
        near_one = fn(*args, 1 - 1e-9)
        assert math.isfinite(at_one)
        assert abs(at_one - near_one) < 1e-7
    assert an.paper_eq6_p0_rp(6, 5, 4, 1.0) == pytest.approx(1.0)


def test_paper_forms_enforce_their_domain():
    with pytest.raises(ValueError, match="r < M and r < N"):
        an.paper_eq6_p0_rp(5, 2, 3, 0.1)
    with pytest.raises(ValueError, match="N < r < M"):
        an.paper_eq7_p0_rp(5, 2, 2, 0.1)
    with pytest.raises(ValueError, match="line"):
        an.paper_eq7_p0_rp(5, 2, 3, 0.1, line=1)


# ----------------------------------------------------------------------------
# Whole message in one round
# ----------------------------------------------------------------------------
@pytest.mark.parametrize("p_e", P_ES)
@pytest.mark.parametrize("strategy", ["rp", "rs"])
def test_p_message_matches_enumeration(p_e, strategy):
    for (M, N), r, n in itertools.product(SMALL_CYCLES, (1, 2, 3, 7, 12), (1, 2, 3, 5, 6, 8, 10, 15)):
        got = an.mmbp_p_message(M, N, r, p_e, n, strategy)
        want = naive_p_message(M, N, r, p_e, n, strategy)
        assert close(got, want, rel=1e-9), (M, N, r, n, p_e, got, want)
        log_got = an.mmbp_log_p_message(M, N, r, p_e, n, strategy)
        assert (want == 0.0 and log_got == -math.inf) or close(log_got, math.log(want), rel=1e-9, abs_=1e-12)


@pytest.mark.parametrize("strategy", ["rp", "rs"])
def test_p_message_independence_approximation(strategy):
    for (M, N), r, n, p_e in itertools.product(SMALL_CYCLES, (1, 3), (1, 5, 14), P_ES):
        p0 = naive_p0_rp(M, N, r, p_e) if strategy == "rp" else naive_p0_rs(M, N, r, p_e, n)
        got = an.mmbp_p_message(M, N, r, p_e, n, strategy, exact=False)
        assert close(got, (1 - p0) ** n, rel=1e-9), (M, N, r, n, p_e)


@pytest.mark.parametrize("r", [1, 2, 5, 10])
def test_fig12_artefact_rs_multiple_of_cycle_is_never_received(r):
    # Paper Fig. 12: RS with N_p a multiple of C = M + N pins every copy of
    # packet k to slot (s + k) mod C, so some packets always fall in the gap.
    for M, N, n in ((5, 2, 49), (5, 2, 7), (3, 1, 8), (1, 6, 14)):
        assert an.mmbp_p_message(M, N, r, 1e-3, n, "rs") == 0.0
        assert an.mmbp_log_p_message(M, N, r, 1e-3, n, "rs") == -math.inf
        # The independence approximation does not see it.
        assert an.mmbp_p_message(M, N, r, 1e-3, n, "rs", exact=False) > 0.0
    # One packet more or less and the message gets through.
    assert an.mmbp_p_message(5, 2, 3, 1e-3, 50, "rs") > 0.9


def test_p_message_huge_counts_are_stable():
    for strategy in ("rp", "rs"):
        for n in (10**6, 10**9, 7 * 10**8):
            for r in (1, 3, 10**6):
                for p_e in P_ES:
                    for M, N in ((5, 2), (0, 3), (4, 0), (1, 6)):
                        lp = an.mmbp_log_p_message(M, N, r, p_e, n, strategy)
                        assert lp <= 0.0 and not math.isnan(lp)
                        assert 0.0 <= an.mmbp_p_message(M, N, r, p_e, n, strategy) <= 1.0
                        assert an.mmbp_log_p_message(M, N, r, p_e, n, strategy, exact=False) <= 0.0


def test_p_message_huge_n_matches_periodic_sum():
    # RP, M=5, N=2, r=3: gcd(3, 7) = 1 so every run of 7 packets starts once
    # in each slot, whatever the phase: log P(n = 7q) = q * sum_u log f(u).
    M, N, r, p_e, q = 5, 2, 3, 0.3, 10**8
    m = [sum((u + j) % 7 < M for j in range(r)) for u in range(7)]
    want = q * sum(math.log1p(-(p_e**mu)) for mu in m)
    assert close(an.mmbp_log_p_message(M, N, r, p_e, 7 * q, "rp"), want, rel=1e-12)


def test_no_cycle_edge_cases():
    # N = 0: every slot ON, exact equals independence; M = 0: nothing received.
    for r, n, p_e in itertools.product((1, 4), (1, 9), (0.0, 0.3, 1.0)):
        assert close(an.mmbp_p_message(4, 0, r, p_e, n, "rp"), (1 - p_e**r) ** n)
        assert an.mmbp_p_message(0, 4, r, p_e, n, "rs") == 0.0


@settings(max_examples=60, deadline=None)
@given(
    M=st.integers(0, 8),
    N=st.integers(0, 8),
    r=st.integers(1, 12),
    n=st.integers(1, 15),
    p_e=st.floats(0.0, 1.0),
    strategy=st.sampled_from(["rp", "rs"]),
)
def test_p_message_property(M, N, r, n, p_e, strategy):
    if M + N == 0:
        return
    got = an.mmbp_p_message(M, N, r, p_e, n, strategy)
    assert 0.0 <= got <= 1.0
    assert close(got, naive_p_message(M, N, r, p_e, n, strategy), rel=1e-9, abs_=1e-13)
    # More copies of every packet never hurt under RP; p0 never grows with r.
    assert an.mmbp_p0_rp(M, N, r + 1, p_e) <= an.mmbp_p0_rp(M, N, r, p_e) + 1e-15


# ----------------------------------------------------------------------------
# Gilbert-Elliott
# ----------------------------------------------------------------------------
def test_ge_convention_matches_eq1():
    # Eq. 1: p = 1 - q = delta_c/delta_f (capture fraction). The printed
    # P_S1 = p/(p+q) is the stationary law of S1 only if p = P(S2 -> S1).
    capture = 0.9
    p, q = capture, 1 - capture
    assert an.ge_stationary(p, q) == pytest.approx((0.9, 0.1))
    ours = np.array([[1 - q, q], [p, 1 - p]])  # rows: from S1, from S2
    pi = np.array(an.ge_stationary(p, q))
    assert np.allclose(pi @ ours, pi)
    # The literal reading (p = P(S1 -> S2)) would make S1 the gap state:
    literal = np.array([[1 - p, p], [q, 1 - q]])
    w, v = np.linalg.eig(literal.T)
    stat = np.real(v[:, np.argmin(abs(w - 1))])
    stat /= stat.sum()
    assert stat[0] == pytest.approx(q / (p + q))  # = 0.1, not the printed 0.9


@pytest.mark.parametrize("p_e", P_ES)
def test_ge_p0_chain_matches_path_enumeration(p_e):
    for p, q in ((0.9, 0.1), (0.3, 0.05), (0.5, 0.9), (1.0, 0.0), (0.0, 0.4), (0.2, 0.2)):
        for r in range(1, 9):
            got = an.ge_p0_rp(p, q, r, p_e, exact=True)
            assert close(got, naive_ge_p0(p, q, r, p_e), rel=1e-10), (p, q, r)


def test_ge_eq3_is_exact_iff_memoryless():
    # With p + q = 1 (the paper's Eq. 1) every row of the transition matrix
    # equals the stationary law: states are i.i.d. and Eq. 3 is exact.
    for p, r, p_e in itertools.product((0.1, 0.5, 0.9), (1, 2, 5, 40), (0.0, 1e-3, 0.3, 1.0)):
        assert close(an.ge_p0_rp(p, 1 - p, r, p_e), an.ge_p0_rp(p, 1 - p, r, p_e, exact=True), rel=1e-12)
    # Otherwise Eq. 3 differs for r >= 2 (bursty: p + q < 1 gives more
    # joint losses; alternating: p + q > 1 fewer); r = 1 always agrees.
    for r in (2, 3, 10):
        assert an.ge_p0_rp(0.09, 0.01, r, 1e-3, exact=True) > an.ge_p0_rp(0.09, 0.01, r, 1e-3) * 1.01
        assert an.ge_p0_rp(0.95, 0.6, r, 1e-3, exact=True) < an.ge_p0_rp(0.95, 0.6, r, 1e-3) * 0.99
    assert close(an.ge_p0_rp(0.09, 0.01, 1, 0.3, exact=True), an.ge_p0_rp(0.09, 0.01, 1, 0.3))


@pytest.mark.parametrize("strategy", ["rp", "rs"])
def test_ge_p_message_against_path_enumeration(strategy):
    for (p, q), p_e, (r, n) in itertools.product(
        ((0.9, 0.1), (0.3, 0.05), (0.6, 0.7), (0.7, 0.3)), (0.0, 0.3, 1.0), ((1, 1), (2, 3), (3, 4), (1, 12), (4, 2))
    ):
        exact = naive_ge_p_message(p, q, r, p_e, n, strategy)
        got = an.ge_p_message(p, q, r, p_e, n, strategy)
        if strategy == "rp" or p + q == 1.0:
            # RP: exact. RS: exact only when memoryless (independence holds).
            assert close(got, exact, rel=1e-10, abs_=1e-15), (p, q, r, n, p_e)
        else:
            # RS: independence across packets, per-packet p0 exact.
            p0 = sum(
                prob * math.prod(p_e if path[k * n] == 0 else 1.0 for k in range(r))
                for path, prob in ge_paths(p, q, (r - 1) * n + 1)
            )
            assert close(got, (1 - p0) ** n, rel=1e-10, abs_=1e-15)
        approx = (1 - ((p * p_e + q) / (p + q)) ** r) ** n
        assert close(an.ge_p_message(p, q, r, p_e, n, strategy, exact=False), approx, rel=1e-10, abs_=1e-15)


def test_ge_rs_independence_is_an_approximation():
    # Bursty chain, RS, 2 packets x 2 copies: the joint differs from the product.
    p, q, p_e = 0.3, 0.05, 0.3
    exact = naive_ge_p_message(p, q, 2, p_e, 2, "rs")
    assert not close(an.ge_p_message(p, q, 2, p_e, 2, "rs"), exact, rel=1e-4)


def test_ge_huge_counts_are_stable():
    for p, q, p_e in ((0.9, 0.1, 1e-3), (0.09, 0.01, 0.3), (1.0, 0.0, 0.0), (0.0, 1.0, 0.5), (0.5, 0.5, 1.0)):
        for r, n in ((1, 10**9), (10**6, 10**9), (3, 50), (10**9, 1)):
            assert 0.0 <= an.ge_p0_rp(p, q, r, p_e, exact=True) <= 1.0
            for strategy in ("rp", "rs"):
                lp = an.ge_log_p_message(p, q, r, p_e, n, strategy)
                assert lp <= 0.0 and not math.isnan(lp)
    # Scaling: log P grows linearly in n for a long message (RP, exact).
    a = an.ge_log_p_message(0.09, 0.01, 2, 0.3, 10**8)
    b = an.ge_log_p_message(0.09, 0.01, 2, 0.3, 2 * 10**8)
    assert close(b, 2 * a, rel=1e-6)


# ----------------------------------------------------------------------------
# Expected emissions and goodput
# ----------------------------------------------------------------------------
@pytest.mark.parametrize("strategy", ["rp", "rs"])
@pytest.mark.parametrize("p_e", [0.0, 1e-3, 0.3])
def test_expected_emissions_match_enumeration(strategy, p_e):
    for (M, N), r, n in itertools.product(((1, 0), (2, 1), (3, 2), (1, 3), (5, 2), (2, 5)), (1, 2, 4), (1, 2, 3, 5)):
        got = an.mmbp_expected_emissions(M, N, r, p_e, n, strategy)
        want = naive_expected_emissions(M, N, r, p_e, n, strategy)
        if math.isinf(want):
            assert math.isinf(got), (M, N, r, n)
        else:
            assert close(got, want, rel=1e-10), (M, N, r, n, got, want)


def test_expected_emissions_monte_carlo():
    rng = np.random.default_rng(12345)
    runs, horizon = 8000, 600
    for M, N, r, p_e, n, strategy in ((5, 2, 2, 0.3, 5, "rp"), (3, 4, 1, 0.2, 6, "rs"), (4, 3, 3, 1e-3, 4, "rp")):
        C = M + N
        t = np.arange(horizon)
        pid = (t % (r * n)) // r if strategy == "rp" else t % n
        phase = rng.integers(0, C, size=runs)
        on = ((phase[:, None] + t[None, :]) % C) < M
        ok = on & (rng.random((runs, horizon)) >= p_e)
        first = np.empty((runs, n), dtype=np.int64)
        for k in range(n):
            cols = np.flatnonzero(pid == k)
            sub = ok[:, cols]
            assert sub.any(axis=1).all()  # horizon long enough
            first[:, k] = cols[sub.argmax(axis=1)]
        T = first.max(axis=1) + 1
        want = an.mmbp_expected_emissions(M, N, r, p_e, n, strategy)
        stderr = T.std(ddof=1) / math.sqrt(runs)
        assert abs(T.mean() - want) < 4.5 * stderr + 1e-9, (M, N, r, p_e, n, strategy, T.mean(), want)


def test_expected_emissions_never_complete():
    assert an.mmbp_expected_emissions(5, 2, 3, 1.0, 10, "rp") == math.inf
    assert an.mmbp_expected_emissions(0, 5, 3, 0.1, 10, "rs") == math.inf
    # Fig. 12 artefact, RS: N_p = 49 is a multiple of C = 7.
    assert an.mmbp_expected_emissions(5, 2, 3, 1e-3, 49, "rs") == math.inf
    # RP is pinned too when r * N_p is a multiple of C and r <= N.
    assert an.mmbp_expected_emissions(5, 2, 1, 1e-3, 7, "rp") == math.inf
    assert math.isfinite(an.mmbp_expected_emissions(5, 2, 3, 1e-3, 7, "rp"))
    assert an.mmbp_expected_goodput_bps(5, 2, 3, 1e-3, 49, "rs", 19, 0.004) == 0.0


def test_expected_emissions_properties():
    # RS emits packet t mod N_p whatever r: E[T] does not depend on r and
    # equals RP with r = 1 (the same endless sequence).
    base = an.mmbp_expected_emissions(5, 2, 1, 0.3, 17, "rp")
    for r in (1, 2, 5):
        assert close(an.mmbp_expected_emissions(5, 2, r, 0.3, 17, "rs"), base, rel=1e-12)
    # p_e = 0, N = 0: every emission is received, T = N_p exactly.
    assert an.mmbp_expected_emissions(3, 0, 1, 0.0, 11, "rp") == 11
    # A paper-sized case stays quick and finite (G = 50 bytes, 3-byte payload).
    e = an.mmbp_expected_emissions(5, 2, 3, 1e-3, 17, "rp")
    assert 3 * 17 * 0.9 < e < 3 * 17 * 3


def test_expected_goodput_definition():
    M, N, r, p_e, n, payload, T_p = 5, 2, 2, 1e-3, 17, 19, 32 / 8000
    e = an.mmbp_expected_emissions(M, N, r, p_e, n, "rp")
    assert an.mmbp_expected_goodput_bps(M, N, r, p_e, n, "rp", payload, T_p) == pytest.approx(payload * n / (e * T_p))


def test_expected_emissions_refuses_intractable_cases():
    with pytest.raises(ValueError, match="hyperperiod"):
        an.mmbp_expected_emissions(5, 2, 1000, 0.1, 10**5, "rp")
    with pytest.raises(ValueError, match="p_e"):
        an.mmbp_expected_emissions(5, 2, 3, 1 - 1e-12, 50, "rp")


# ----------------------------------------------------------------------------
# ROI and slots from physics
# ----------------------------------------------------------------------------
def test_roi_ratio_paper_values_and_units_note():
    # Fig. 11: fc = 35, ss = 5.7, l = 10 (mm); d = 10 cm.
    assert an.roi_ratio(100, 10, 35, 5.7) == pytest.approx(10 * 35 / (100 * 5.7))
    assert an.roi_ratio(20, 10, 35, 5.7) == 1.0
    # With the Nexus 5's real 3.97 mm focal length the ROI is ~8.8x smaller.
    ratio = an.roi_ratio(300, 10, 35, 5.7) / an.roi_ratio(300, 10, 3.97, 5.7)
    assert ratio == pytest.approx(35 / 3.97)
    for bad in ({"distance_mm": 0}, {"distance_mm": -1}, {"led_size_mm": 0}, {"focal_length_mm": -3}):
        kwargs = {"distance_mm": 50, "led_size_mm": 4, "focal_length_mm": 3.97, "sensor_size_mm": 5.7, **bad}
        with pytest.raises(ValueError, match=next(iter(bad))):
            an.roi_ratio(**kwargs)


def test_slots_from_physics():
    T_f, T_p = 1 / 30, 0.006  # C = round(5.56) = 6
    slots = an.mmbp_slots_from_physics(T_f, 0.9 * T_f, T_p)  # W/T_p - 1 = 4
    assert (slots.M, slots.N, slots.cycle_slots) == (4, 2, 6)
    assert slots.mean_whole_sdus_per_frame == pytest.approx(4.0)
    assert an.mmbp_slots_from_physics(T_f, 0.5 * T_p, T_p).M == 0  # nothing fits whole
    huge = an.mmbp_slots_from_physics(T_f, 10 * T_f, T_p)
    assert huge.M == huge.cycle_slots and huge.N == 0
    assert an.mmbp_slots_from_physics(T_f, T_f, 1.0).cycle_slots == 1  # at least one slot
    with pytest.raises(ValueError, match="sdu_duration_s"):
        an.mmbp_slots_from_physics(T_f, T_f, 0.0)
    with pytest.raises(AttributeError):
        slots.M = 3  # frozen


def _whole_sdus_by_enumeration(window_s: float, sdu_s: float, phases: int = 20000) -> float:
    """Mean count of whole PHY-SDUs in [0, W] over an even grid of start phases."""
    offsets = (np.arange(phases) + 0.5) / phases * sdu_s  # first start at or after 0
    ends = offsets[:, None] + sdu_s * (np.arange(int(window_s / sdu_s) + 2)[None, :] + 1)
    return float((ends <= window_s).sum(axis=1).mean())


@pytest.mark.parametrize("window_ratio", [0.3, 1.0, 1.5, 3.34, 7.9])
def test_throughput_bound_counts_whole_sdus_by_enumeration(window_ratio):
    T_f, T_p, bits = 1 / 30, 0.0065, 24
    W = window_ratio * T_p
    expected = bits * _whole_sdus_by_enumeration(W, T_p) / T_f
    assert an.throughput_bound_bps(T_f, W, T_p, bits) == pytest.approx(expected, rel=1e-3, abs=1e-6)


def test_throughput_bound_of_the_papers_10_cm_testbed():
    # Fig. 11's ROI at 10 cm, 30 fps, IFG 0.1: at most 1686 bit/s for 6.5 ms
    # PHY-SDUs of 24 bits, below the 1940 bit/s Fig. 16 reports there.
    W = an.capture_window_s(1 / 30, 0.1, 0.724)
    assert an.throughput_bound_bps(1 / 30, W, 6.5e-3, 24) == pytest.approx(1685.9, abs=0.1)
    assert an.throughput_bound_bps(1 / 30, 0.0, 6.5e-3, 24) == 0.0
    for bad in ("frame_period_s", "sdu_duration_s", "bits_per_sdu"):
        kwargs = {"frame_period_s": 1 / 30, "capture_window_s": W, "sdu_duration_s": 6.5e-3, "bits_per_sdu": 24,
                  bad: -1.0}
        with pytest.raises(ValueError, match=bad):
            an.throughput_bound_bps(**kwargs)


def test_capture_window():
    assert an.capture_window_s(1 / 30, 0.1, 0.5, 1e-4) == pytest.approx(1 / 30 * 0.9 * 0.5 + 1e-4)
    for kwargs, name in (({"ifg_ratio": 1.0}, "ifg_ratio"), ({"roi": 1.5}, "roi"), ({"exposure_s": -1}, "exposure_s")):
        args = {"frame_period_s": 1 / 30, "ifg_ratio": 0.1, "roi": 0.5, **kwargs}
        with pytest.raises(ValueError, match=name):
            an.capture_window_s(**args)


# ----------------------------------------------------------------------------
# Input validation
# ----------------------------------------------------------------------------
@pytest.mark.parametrize(
    "call, name",
    [
        (lambda: an.mmbp_p0_rp(-1, 2, 1, 0.1), "M"),
        (lambda: an.mmbp_p0_rp(1, -2, 1, 0.1), "N"),
        (lambda: an.mmbp_p0_rp(0, 0, 1, 0.1), "C = M \\+ N"),
        (lambda: an.mmbp_p0_rp(1, 2, 0, 0.1), "r"),
        (lambda: an.mmbp_p0_rp(1, 2, 1.5, 0.1), "r"),
        (lambda: an.mmbp_p0_rp(1, 2, 1, 1.1), "p_e"),
        (lambda: an.mmbp_p0_rp(1, 2, 1, float("nan")), "p_e"),
        (lambda: an.mmbp_p0_rs(1, 2, 1, 0.1, 0), "n_packets"),
        (lambda: an.mmbp_p_message(1, 2, 1, 0.1, 3, "rq"), "strategy"),
        (lambda: an.mmbp_expected_emissions(1, 2, 1, 0.1, 3, "xx"), "strategy"),
        (lambda: an.ge_p0_rp(0.0, 0.0, 1, 0.1), "p \\+ q"),
        (lambda: an.ge_p0_rp(-0.1, 0.5, 1, 0.1), "p"),
        (lambda: an.ge_p_message(0.1, 0.5, 1, 0.1, 3, "zz"), "strategy"),
        (lambda: an.mmbp_expected_goodput_bps(5, 2, 1, 0.1, 3, "rp", 0, 1e-3), "payload_bits"),
    ],
)
def test_invalid_inputs_name_the_parameter(call, name):
    with pytest.raises(ValueError, match=name):
        call()


def test_accepts_integral_floats_and_numpy_scalars():
    assert an.mmbp_p0_rp(np.int64(5), 2.0, 1e6, np.float64(0.3)) == an.mmbp_p0_rp(5, 2, 10**6, 0.3)
