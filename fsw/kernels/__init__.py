"""Compiled (numba) kernels of the onboard arithmetic: one kernel per equation, named for it.

Importing this package fixes where numba keeps its on-disk cache *before* numba is imported
(:mod:`fsw.kernels.cache`). Each kernel module compiles its kernels with explicit signatures and
``cache=True``: the machine code is compiled (first process) or loaded from the cache when the
module is imported, and an argument of another dtype or rank is a ``TypeError`` instead of a
silent recompilation in the hot loop. A fused kernel may call the kernels of other modules: every
cached kernel is stamped with all the kernels' sources (:func:`stamp_with_all_kernel_sources`),
since numba's own stamp (the function's file) would keep a caller's stale copy of a changed callee.

The measurement models sit under the configuration (the kinds they model are what a filter may
process), and every process that reads a scenario imports them: the launcher, the simulator,
the ground tools. Those never run a kernel, and importing numba and loading the kernels costs
~0.45 s. So the models name their kernels through :func:`on_first_call`, and the kernel modules
are imported when the FSW core is built (:func:`load_all`, from ``FswCore.__init__``) — never
inside an executive frame — or, for other users of the models, at the first call.
"""

from __future__ import annotations

import importlib
from typing import Any, Callable

from fsw.kernels.cache import configure_cache_dir, stamp_with_all_kernel_sources

configure_cache_dir()

#: (namespace, name, kernel module) of every stand-in made, in order.
_STAND_INS: list[tuple[dict[str, Any], str, str]] = []


def _bind(namespace: dict[str, Any], name: str, module: str) -> Callable[..., Any]:
    kernel = getattr(importlib.import_module(module), name)
    namespace[name] = kernel
    return kernel


def on_first_call(namespace: dict[str, Any], name: str, module: str) -> Callable[..., Any]:
    """A stand-in for kernel ``name`` of ``module``, to be bound to ``name`` in ``namespace`` (the
    caller's ``globals()``): its first call imports the kernel module, puts the kernel in its own
    place, and calls it. From then on the name is the kernel itself: calls cost nothing extra."""

    def stand_in(*args: Any) -> Any:
        return _bind(namespace, name, module)(*args)

    stand_in.__name__ = stand_in.__qualname__ = name
    stand_in.__doc__ = f"Loads {module}.{name} on its first call (fsw.kernels.on_first_call)."
    _STAND_INS.append((namespace, name, module))
    return stand_in


def load_all() -> None:
    """Import every kernel module a stand-in waits for, and bind the kernels in their places."""
    for namespace, name, module in _STAND_INS:
        current = namespace.get(name)
        if getattr(current, "__module__", None) == __name__:  # still the stand-in
            _bind(namespace, name, module)


__all__ = ["configure_cache_dir", "load_all", "on_first_call", "stamp_with_all_kernel_sources"]
