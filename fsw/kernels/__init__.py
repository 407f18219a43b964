"""Compiled (numba) kernels of the onboard arithmetic: one kernel per equation, named for it.

Importing this package fixes where numba keeps its on-disk cache *before* numba is imported
(:mod:`fsw.kernels.cache`). Each kernel module compiles its kernels with explicit signatures and
``cache=True``: the machine code is compiled (first process) or loaded from the cache when the
module is imported, i.e. while the FSW core is built — never inside an executive frame — and an
argument of another dtype or rank is a ``TypeError`` instead of a silent recompilation in the
hot loop. A kernel calls only helpers of its own module: numba does not invalidate a cached
caller when an njit helper in another module changes.
"""

from fsw.kernels.cache import configure_cache_dir

configure_cache_dir()
