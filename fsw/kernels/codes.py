"""Return codes of the kernels, importable without numba (the models that test them name their
kernels lazily: :func:`fsw.kernels.on_first_call`)."""

#: :func:`fsw.kernels.camera.pinhole_image`: the image is good; a line of sight is zero; a target
#: is behind the camera.
OK, AT_TARGET, BEHIND_CAMERA = 0, 1, 2

#: :func:`fsw.kernels.magill.magill_update`: done; an innovation covariance is not positive
#: definite; a measurement of more than two components (left to the Python form).
MAGILL_OK, MAGILL_NOT_POSITIVE_DEFINITE, MAGILL_UNHANDLED_DIMENSION = 0, 1, 2

#: :func:`fsw.kernels.bplane.bplane_complex_step`: done; the state has no B-plane (bound, radial,
#: asymptote along the pole, or a non-finite result).
BPLANE_OK, BPLANE_DEGENERATE = 0, 1

#: :func:`fsw.kernels.record_check.record_values_status`: every number finite and every
#: chi-square ≥ 0; a NaN or an infinity somewhere; a negative chi-square.
RECORD_OK, RECORD_NON_FINITE, RECORD_NEGATIVE_CHI2 = 0, 1, 2
