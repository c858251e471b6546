"""The look-up of a compiled entry point that costs no compilation (numba's dispatcher).

``update``'s narrow step entry (:mod:`adaptid._kernels.recursions._step`) is
taken only when its machine code is at hand: compiled in this process, in
numba's cache folder, or compiled at install. numba has no public call for
"load from the cache, do not compile", so :func:`entry_point` reads the
dispatcher's overloads and its cache as numba's own ``Dispatcher.compile``
does. Patch ``step-entry`` of :mod:`._patches`: with ``ADAPTID_STEP_ENTRY=0``
or ``ADAPTID_NUMBA_PATCHES=0`` it returns None, and ``update`` is always a run
of length 1 through ``run``.
"""

from ._patches import enabled

__all__ = ["entry_point"]


def entry_point(dispatcher, args):
    """The compiled ``dispatcher`` for ``args`` if that costs no compilation, else None.

    Looks in this process's compiled overloads, then in the cache (numba's
    folder, then the kernels compiled at install); a hit is added to the
    dispatcher as numba's own ``compile`` adds one. None with
    ``NUMBA_DISABLE_JIT=1``, when patch ``step-entry`` is off, or when numba's
    internals differ from what this expects.
    """
    if not enabled("step-entry"):
        return None
    try:
        import numba
        from numba.core.compiler_lock import global_compiler_lock
        key = tuple(numba.typeof(a) for a in args)
        with global_compiler_lock:  # as numba's own ``Dispatcher.compile``
            found = dispatcher.overloads.get(key)
            if found is None:
                cres = dispatcher._cache.load_overload(key, dispatcher.targetctx)
                if cres is None:
                    return None
                dispatcher._cache_hits[key] += 1
                dispatcher.targetctx.insert_user_function(cres.entry_point, cres.fndesc,
                                                          [cres.library])
                dispatcher.add_overload(cres)
                found = dispatcher.overloads[key]
        return found.entry_point
    except Exception:  # noqa: BLE001 - NUMBA_DISABLE_JIT, numba internals that differ
        return None
