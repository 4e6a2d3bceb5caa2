"""rollsim: a physically based rolling-shutter simulator for optical camera communication."""

__version__ = "0.1.0"
