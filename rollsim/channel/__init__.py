"""Channel layer: analytic MMBP / Gilbert-Elliott models and the event simulator."""
