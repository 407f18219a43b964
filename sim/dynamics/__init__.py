"""Truth dynamics: force models, their stochastic realisation and the numerical propagator.

Written independently of the onboard models in ``fsw.models`` on purpose.
"""
