"""The stages after the render, each a command's work on files or in memory.

:mod:`~rollsim.stages.decode` (the decoder over a directory of frames),
:mod:`~rollsim.stages.evaluate` (every emission's outcome against the
truth), :mod:`~rollsim.stages.genie` (the genie-aided reference receiver),
:mod:`~rollsim.stages.describe` (what a scene predicts, without rendering),
and below them :mod:`~rollsim.stages.records` (the JSON-lines files and the
decoded PHY-SDUs' schema), :mod:`~rollsim.stages.receiver` (the message
reassembled from decoded PHY-SDUs) and :mod:`~rollsim.stages.compare` (two
decoders outcome by outcome).
"""
