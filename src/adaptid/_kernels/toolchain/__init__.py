"""The numba toolchain of the kernels: every use of numba's internals lives here.

* :mod:`._patches` — the registry of the patches of numba internals below,
  each with a switch (``ADAPTID_NUMBA_PATCHES=0`` turns all off) and a plain
  fallback;
* :mod:`._cache` — the cache locators (one trusted folder, a stamp per kernel
  module) and the cache that treats a damaged file as a miss;
* :mod:`._installed` — the kernels compiled at install (``_kernels/_aot``);
* :mod:`._inline` — the faster copy in numba's inliner;
* :mod:`._dispatch` — the look-up of ``update``'s step entry in numba's dispatcher;
* :mod:`._dims` — the typing templates that make n and p compile-time constants;
* :mod:`._scratch`, :mod:`._lanes_ir` — stack work arrays and the lane primitives;
* :mod:`._vecir`, :mod:`._covsweep`, :mod:`._potter_ir` — LLVM vector IR of the
  sweeps of the square-root and covariance forms;
* :mod:`._specialise` — compile-time choices of an implementation by type.

The recursions (``recursions/``), the lanes (``lanes/``) and the other layers'
kernels (``layers/``) use numba's public API only (``njit``, ``prange``,
``types``) and what this package exports.
"""


def patch_status() -> list:
    """:func:`._patches.status`, with whether the cache locators and the inliner are in
    place in this process (what ``adaptid info`` prints)."""
    from . import _patches
    from ._cache import installed as locators
    from ._inline import installed as inliner

    return _patches.status({"cache-locators": locators(), "fast-inline": inliner()})
