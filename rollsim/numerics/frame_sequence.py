"""Per-scene random sequences indexed by frame: draws and their running sums.

A sequence x_0, x_1, … of i.i.d. (optionally truncated) standard normal
vectors comes from one per-scene stream, cut into blocks of
:data:`BLOCK_FRAMES` frames: block b is drawn from
``rollsim.numerics.seeds.rng(seed, stream, b)``. So x_k, and the walk
W_k = x_0 + … + x_{k−1} (a sum of k steps, W_0 = 0), depend only on the seed,
the stream and k: not on which frames were rendered before, nor on the number
of workers. W_k costs one block's cumulative sum plus, once per process, the
block totals up to k's block; they are summed in one fixed order, so W_k is
the same float however it is reached.
"""

from __future__ import annotations

from collections import OrderedDict

import numpy as np

from rollsim.numerics.seeds import rng as named_rng
from rollsim.numerics.gaussian import truncated_normal

BLOCK_FRAMES = 1024
_CACHED_BLOCKS = 4


def _frame_indices(frames) -> np.ndarray:
    frames = np.atleast_1d(np.asarray(frames, dtype=np.int64))
    if frames.size and frames.min() < 0:
        raise ValueError(f"frame indices must be >= 0, got {int(frames.min())}")
    return frames


class FrameSequence:
    """Standard normal vectors x_k per frame, and their walk W_k.

    Parameters
    ----------
    seed : int
        Scene seed.
    stream : str
        Stream name, e.g. ``"frame_jitter"``.
    dims : int
        Length of each x_k.
    bound : float
        Truncation of each component to [−bound, bound] (``inf``: none).
    """

    def __init__(self, seed: int, stream: str, dims: int = 1, bound: float = np.inf):
        self.seed, self.stream, self.dims, self.bound = seed, stream, dims, bound
        self._blocks: OrderedDict[int, tuple[np.ndarray, np.ndarray]] = OrderedDict()
        # _walk_at_block[b] = W at the first frame of block b.
        self._walk_at_block = [np.zeros(dims)]

    def _block(self, b: int) -> tuple[np.ndarray, np.ndarray]:
        """Draws of block b and their inclusive cumulative sum, shape (BLOCK_FRAMES, dims)."""
        if b in self._blocks:
            self._blocks.move_to_end(b)
            return self._blocks[b]
        uniform = named_rng(self.seed, self.stream, b).random((BLOCK_FRAMES, self.dims))
        draws = truncated_normal(uniform, 1.0, self.bound)
        entry = (draws, np.cumsum(draws, axis=0))
        self._blocks[b] = entry
        if len(self._blocks) > _CACHED_BLOCKS:
            self._blocks.popitem(last=False)
        return entry

    def draws(self, frames) -> np.ndarray:
        """x_k for frame indices ``frames`` (≥ 0), shape (n, dims)."""
        frames = _frame_indices(frames)
        out = np.empty((frames.size, self.dims))
        for b in np.unique(frames // BLOCK_FRAMES):
            sel = frames // BLOCK_FRAMES == b
            out[sel] = self._block(int(b))[0][frames[sel] % BLOCK_FRAMES]
        return out

    def walk(self, frames) -> np.ndarray:
        """W_k = x_0 + … + x_{k−1} for frame indices ``frames`` (≥ 0), shape (n, dims)."""
        frames = _frame_indices(frames)
        out = np.empty((frames.size, self.dims))
        for b in np.unique(frames // BLOCK_FRAMES):
            b = int(b)
            while len(self._walk_at_block) <= b:
                last = len(self._walk_at_block) - 1
                self._walk_at_block.append(self._walk_at_block[last] + self._block(last)[1][-1])
            sel = frames // BLOCK_FRAMES == b
            within = frames[sel] % BLOCK_FRAMES
            cumulative = self._block(b)[1]
            steps = np.where((within > 0)[:, None], cumulative[np.maximum(within - 1, 0)], 0.0)
            out[sel] = self._walk_at_block[b] + steps
        return out
