"""Return codes of the kernels, importable without numba (the models that test them name their
kernels lazily: :func:`fsw.kernels.on_first_call`)."""

#: :func:`fsw.kernels.camera.pinhole_image`: the image is good; a line of sight is zero; a target
#: is behind the camera.
OK, AT_TARGET, BEHIND_CAMERA = 0, 1, 2
