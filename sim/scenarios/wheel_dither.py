"""The spacecraft case of residual-correlation hypothesis testing (Hanlon & Maybeck 2000): a reaction-wheel
failure in a three-axis spacecraft holding attitude, found from a small known wheel-torque dither.

Model (linearised about an inertial hold; small angles, gyroscopic coupling negligible at the hold's
rates of ~1e-5 rad/s):

* rigid body, principal inertia J = diag(400, 350, 250) kg m² (a ~500 kg spacecraft);
* four reaction wheels in the standard pyramid: spin axes a_i = [cos β cos φ_i, cos β sin φ_i, sin β]
  with β = 35.26° and φ_i = 45°, 135°, 225°, 315°; a wheel torque command τ_i accelerates the body by
  −J⁻¹ a_i τ_i (the reaction), so column i of B is −J⁻¹ a_i [rad/s² per N m];
* every wheel carries a sinusoidal torque dither of 0.02 N m (multiplier 1.0; a tenth of a
  0.2 N m wheel, an attitude jitter below 1 arcsec) at its own frequency, 0.05 / 0.08 / 0.11 / 0.14
  cycles per sample = 0.5 / 0.8 / 1.1 / 1.4 Hz at the 10 Hz attitude-control rate; the closest two are
  0.03 cycles per sample apart, so an N = 100 window (resolution 2/N = 0.02) separates them, as in
  Hanlon & Maybeck's choice of N;
* measurements at 10 Hz: a three-axis gyro (white rate noise 5e-6 rad/s, 1σ) and a star tracker
  (10 arcsec, 1σ, per axis, small-angle attitude errors);
* unmodelled disturbance torques as white process noise on the rates, 1e-7 rad/s per step (1σ).

Hypotheses: ``nominal`` and ``wheelj-failed`` (wheel j gives no torque; a failed wheel's dither and
control torques vanish). The attitude controller's own torques are known to every filter alike and
cancel from the residual differences between filters; they are left out, so the truth is the open-
loop hold with the dither. See :mod:`sim.scenarios.dither_case` for the construction.
"""

from __future__ import annotations

import numpy as np

from sim.scenarios.dither_case import DitherCase

DT = 0.1  # s: 10 Hz attitude-control and measurement rate
INERTIA = np.diag([400.0, 350.0, 250.0])  # kg m²
ELEVATION = np.deg2rad(35.26)  # pyramid: spin axes 54.74° from the body z axis
AZIMUTHS = np.deg2rad([45.0, 135.0, 225.0, 315.0])
#: spin axis of each wheel (columns)
AXES = np.stack([np.cos(ELEVATION) * np.cos(AZIMUTHS), np.cos(ELEVATION) * np.sin(AZIMUTHS),
                 np.full(4, np.sin(ELEVATION))])
#: body angular acceleration per N m of wheel torque command (the reaction) [rad/s² per N m]
B = -np.linalg.solve(INERTIA, AXES)
FREQUENCIES = (0.05, 0.08, 0.11, 0.14)  # cycles per sample
AMPLITUDE = 0.02  # N m of wheel torque dither at multiplier 1.0
RATE_NOISE = 1e-7  # rad/s per step: unmodelled disturbance torques
ATTITUDE_SIGMA = np.deg2rad(10.0 / 3600.0)  # rad: star tracker, 10 arcsec per axis
GYRO_SIGMA = 5e-6  # rad/s

CASE = DitherCase("spacecraft, four reaction wheels", DT, B, FREQUENCIES, AMPLITUDE, RATE_NOISE,
                  ATTITUDE_SIGMA, GYRO_SIGMA, actuator="wheel")
