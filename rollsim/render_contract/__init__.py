"""What the render hands the effects: the per-scene setup and the state of one frame.

:class:`~rollsim.render_contract.setup.SceneSetup` (built by
:func:`~rollsim.render_contract.setup.build_setup`) and
:class:`~rollsim.render_contract.state.FrameState`. They sit below
:mod:`rollsim.effects`, so that an effect names them without importing
the render above it.
"""
