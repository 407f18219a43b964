"""Shared astrodynamics: constants, time scales, frames, DE421 ephemeris, Mars moons, DSN stations.

Modules: ``constants``, ``time``, ``frames``, ``ephemeris``, ``moons``, ``earth``, ``stations``.
All epochs are ``t_tdb``, seconds of TDB past J2000.0; all vectors are ICRF axes in km and km/s.
"""
