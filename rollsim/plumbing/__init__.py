"""What every command shares, whatever it computes.

Argument checks (:mod:`~rollsim.plumbing.validation`), SIGINT and SIGTERM
(:mod:`~rollsim.plumbing.signals`), staged outputs
(:mod:`~rollsim.plumbing.outputs`), the worker pool
(:mod:`~rollsim.plumbing.parallel`), the memory and disk budget
(:mod:`~rollsim.plumbing.budget`), numbers and tables as text
(:mod:`~rollsim.plumbing.text_tables`) and the modules that are also API
functions (:mod:`~rollsim.plumbing.callable_module`). The error types are
:mod:`rollsim.errors`.
"""
