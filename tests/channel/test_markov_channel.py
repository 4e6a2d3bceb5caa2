"""The Gilbert-Elliott channel of the event simulator against the chain's closed forms."""

from __future__ import annotations

import numpy as np
import pytest

from rollsim.calibrate.compare import run_lengths
from rollsim.channel.channels import DECODE_ERROR, GAP_LOSS, RECEIVED
from rollsim.channel.markov import GeChannel


def _outcomes(channel, blocks, seed=5):
    run = channel.open_run(np.random.SeedSequence(seed))
    return np.concatenate([run.next_block(b) for b in blocks])


@pytest.mark.parametrize("blocks", [[200_000] * 2, [1, 7, 3, 1000, 13] * 3000])
def test_states_follow_the_chain_across_blocks(blocks):
    """S1's share is p / (p + q), its sojourns are geometric with mean 1/q and S2's with mean 1/p,
    whatever the sizes of the blocks a run is read in (the chain carries over)."""
    p, q, p_e = 0.3, 0.1, 0.2
    codes = _outcomes(GeChannel(p, q, p_e, 0.007), blocks)
    in_s1 = codes != GAP_LOSS
    n = codes.size
    share = in_s1.mean()
    # The chain's states are correlated (eigenvalue 1 − p − q): the variance of their mean grows by (2 − p − q) / (p + q).
    inflation = (2 - p - q) / (p + q)
    assert abs(share - p / (p + q)) < 4 * np.sqrt(share * (1 - share) / n * inflation)
    runs = run_lengths(in_s1)
    assert runs["success"].mean() == pytest.approx(1 / q, rel=0.05)
    assert runs["loss"].mean() == pytest.approx(1 / p, rel=0.05)
    errors = np.count_nonzero(codes == DECODE_ERROR) / np.count_nonzero(in_s1)
    assert errors == pytest.approx(p_e, abs=0.01)
    assert set(np.unique(codes)) <= {RECEIVED, GAP_LOSS, DECODE_ERROR}


def test_a_run_is_its_seed():
    channel = GeChannel(0.2, 0.05, 0.01, 0.007)
    assert np.array_equal(_outcomes(channel, [500, 500], seed=9), _outcomes(channel, [500, 500], seed=9))


@pytest.mark.parametrize("field, value", [("p", 0.0), ("q", 1.5), ("p_e", -0.1), ("sdu_duration_s", 0.0)])
def test_bad_parameters_are_named(field, value):
    kwargs = {"p": 0.2, "q": 0.1, "p_e": 0.0, "sdu_duration_s": 0.007, field: value}
    with pytest.raises(ValueError, match=field):
        GeChannel(**kwargs)
