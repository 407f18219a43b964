"""Physical and astronomical constants used by navbank (km, s, kg, rad unless stated).

Only nature's measured constants and defined ones (c, the AU, the WGS84 ellipsoid, the ERA rate,
epochs) live here, because the simulator shares this module with the FSW (the import rule of
docs/architecture.md): a *model* parameter — the Mars rotation model, a nutation series — belongs
to its onboard model module, and the simulator's truth has its own.

Gravitational parameters are the DE421 values (Folkner, Williams & Boggs 2009, as published in
NAIF's ``gm_de421.tpc``), so that the dynamics and the ephemeris form a consistent set.
Their consistency with the constants shipped inside the ``de421`` package is checked by a test.
"""

from __future__ import annotations

import math

from fsw.interface.kinds import DOPPLER_CARRIER_HZ

# --- gravitational parameters [km^3/s^2], DE421 -------------------------------------------------
GM_SUN: float = 132712440040.944
GM_EARTH: float = 398600.436233
GM_MOON: float = 4902.800076
GM_EARTH_MOON: float = GM_EARTH + GM_MOON  # Earth-Moon system (barycentre)
GM_MARS_SYSTEM: float = 42828.375214  # Mars + Phobos + Deimos
GM_MARS: float = GM_MARS_SYSTEM  # the moons add < 1e-9 relative; Mars-centred dynamics use the system value
GM_JUPITER_SYSTEM: float = 126712764.800000

# --- light, distance, time ------------------------------------------------------------------------
C_KM_S: float = 299792.458  # speed of light (exact)
AU_KM: float = 149597870.700  # astronomical unit (IAU 2012 B2, exact)
SECONDS_PER_DAY: float = 86400.0
DAYS_PER_JULIAN_CENTURY: float = 36525.0
SECONDS_PER_JULIAN_CENTURY: float = SECONDS_PER_DAY * DAYS_PER_JULIAN_CENTURY

# --- epochs ------------------------------------------------------------------------------------------
JD_J2000: float = 2451545.0  # J2000.0 = 2000-01-01T12:00:00 TT (and, as the origin of t_tdb, TDB)
MJD_OFFSET: float = 2400000.5  # JD = MJD + MJD_OFFSET
J2000_TT_ISO: str = "2000-01-01T12:00:00"  # label of the epoch in TT
J2000_UTC_ISO: str = "2000-01-01T11:58:55.816"  # the same instant in UTC (TAI-UTC = 32 s)
UNIX_AT_J2000_UTC_NOON: float = 946728000.0  # Unix seconds of 2000-01-01T12:00:00 UTC
TT_MINUS_TAI_S: float = 32.184  # exact by definition

# --- solar radiation pressure -------------------------------------------------------------------
SOLAR_FLUX_1AU_W_M2: float = 1361.0  # total solar irradiance at 1 AU (Kopp & Lean 2011)
P_SUN_1AU_N_M2: float = SOLAR_FLUX_1AU_W_M2 / (C_KM_S * 1e3)  # ~4.54e-6 N/m^2 on an absorbing surface

# --- bodies ----------------------------------------------------------------------------------------
R_MARS_EQ_KM: float = 3396.19  # Mars equatorial radius (IAU WGCCRE 2009, Archinal et al. 2011)
R_EARTH_EQ_KM: float = 6378.137  # WGS84 semi-major axis
F_EARTH: float = 1.0 / 298.257223563  # WGS84 flattening

# Earth rotation: rate of the Earth Rotation Angle (IAU 2000 B1.8), rad per UT1 second.
ERA_RATE_CYCLES_PER_UT1_DAY: float = 1.00273781191135448
OMEGA_EARTH_RAD_S: float = 2.0 * math.pi * ERA_RATE_CYCLES_PER_UT1_DAY / SECONDS_PER_DAY  # 7.2921159e-5

# --- radio ----------------------------------------------------------------------------------------
# The carrier is the ICD's (fsw.interface.kinds: one-way uplink Doppler, X-band uplink carrier):
# f_D = -(F/c) * range_rate, so 1 mHz of Doppler is this range rate [km/s per mHz]
# (~4.19e-8 km/s = 0.042 mm/s).
MHZ_TO_KM_S: float = C_KM_S / DOPPLER_CARRIER_HZ * 1e-3
