"""Numbers with the same bits everywhere, shared by the physics and the channel.

Exact cycle positions of a clock (:mod:`~rollsim.numerics.clock`),
counter-based random words (:mod:`~rollsim.numerics.counter_rng`), normal
deviates (:mod:`~rollsim.numerics.gaussian`), named seeds
(:mod:`~rollsim.numerics.seeds`), per-frame random sequences and walks
(:mod:`~rollsim.numerics.frame_sequence`), exp, log, arcsin and power with
the same bits on every CPU (:mod:`~rollsim.numerics.portable_math`),
numba kernels with numpy twins (:mod:`~rollsim.numerics.jit`) and the
Gilbert-Elliott likelihood that calibration evaluates thousands of times
(:mod:`~rollsim.numerics.ge_likelihood`).
"""
