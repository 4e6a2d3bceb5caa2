"""Benchmarks: what each part costs in time and memory on this machine.

Each benchmark returns a JSON-ready dict and prints a small table; they run
from one command each (``rollsim bench render``, ...). Speed targets live
here, never in unit tests.
"""
