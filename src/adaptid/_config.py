"""Numba flags, the compilation-cache policy and numerical thresholds, in one place.

Every compiled kernel takes its decorator options from here, so that the
whole library can be switched at once (e.g. ``NUMBA_DISABLE_JIT=1`` for
coverage of the kernels' Python source).

Compilation cache
-----------------
numba's cache files (``.nbi`` indexes and ``.nbc`` code) are pickles: loading
one runs code. So adaptid caches only in a folder nobody else can write. Once,
when this module is imported, it finds the folder numba would use for the
kernels in ``adaptid/_kernels`` (numba's own order: ``NUMBA_CACHE_DIR``, then
the in-tree ``__pycache__``, then the user-wide ``~/.cache/numba``, each only
if it exists or can be created and is writable) and checks that it is
*trusted*: a directory (not a symbolic link) owned by the current user or
root, not writable by group or others, every folder above it up to ``/``
owned by the current user or root and not writable by group or others unless
it has the sticky bit (a sticky folder of another user does not protect: its
owner can swap anything in it). If it is, :data:`CACHE` is True and kernels are cached there;
otherwise nothing is cached or loaded from disk and one
:class:`~adaptid.CompilationCacheWarning` says why (a read-only install with
an unwritable HOME then works, compiling in every process). A kernel missing
from the cache folder is loaded from the kernels compiled when adaptid was
installed, if they match (:mod:`adaptid._kernels.toolchain._installed`). A damaged cache
file (truncated ``.nbc``, garbage ``.nbi``) is treated as a miss: the kernel
is recompiled and the entry rewritten (:func:`njit`). Loading a cached kernel
starts numba's runtime only, not its compiler's registries
(:mod:`adaptid._kernels.toolchain._cache`): a process whose kernels all come
from the cache does not pay for them.

This check is made once; the folder could still be swapped afterwards by
someone who can write a folder above it. So every read of an index or code
file re-verifies it (patch ``tolerant-cache``,
:mod:`adaptid._kernels.toolchain._cache`): the folder is opened without
following symbolic links and held, its owner and mode checked on the open
descriptor, and each file opened relative to it must be a regular file of the
user or root that group and others cannot write; otherwise nothing is
unpickled, the kernel is compiled in memory and one
:class:`~adaptid.CompilationCacheWarning` says why. With the patch off
(``ADAPTID_NUMBA_PATCHES=0``) numba reads by path and only the import-time
check protects.
"""

import os
import stat
import sys
import warnings

from ._exceptions import CompilationCacheWarning

_KERNELS = os.path.join(os.path.dirname(os.path.abspath(__file__)), "_kernels")


def _user_cache_root():
    """numba's user-wide cache folder (``AppDirs("numba").user_cache_dir``)."""
    home = os.path.expanduser("~")
    if sys.platform == "darwin":
        return os.path.join(home, "Library", "Caches", "numba")
    if os.name == "nt":
        base = os.environ.get("LOCALAPPDATA") or os.path.join(home, "AppData", "Local")
        return os.path.join(base, "numba", "Cache")
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(home, ".cache")
    return os.path.join(base, "numba")


def _subpath(folder):
    """numba's sub-folder of a cache root for sources in ``folder``."""
    import hashlib
    return "_".join([os.path.basename(folder), hashlib.sha1(folder.encode()).hexdigest()])


def _usable(path):
    """numba's test: the folder exists or can be created, and is writable."""
    try:
        os.makedirs(path, mode=0o755, exist_ok=True)
    except OSError:
        return False
    return os.path.isdir(path) and os.access(path, os.W_OK | os.X_OK)


def _ancestors(path):
    """The folders above ``path`` up to ``/``: of its absolute path and of its real
    path (a symlinked component is judged by the folders on both sides)."""
    out = []
    for start in (os.path.abspath(path), os.path.realpath(path)):
        folder = os.path.dirname(start)
        while True:
            if folder not in out:
                out.append(folder)
            up = os.path.dirname(folder)
            if up == folder:
                break
            folder = up
    return out


def _untrusted_ancestor(path):
    """Why a folder above ``path`` lets another user swap it, or None.

    Every ancestor up to ``/`` must belong to the current user or root, and be
    writable by group or others only with the sticky bit (which protects only
    because the folder's owner is the user or root).
    """
    me = os.getuid()
    for folder in _ancestors(path):
        try:
            st = os.stat(folder)
        except OSError as err:
            return f"is in {folder}, which cannot be inspected ({err.strerror})"
        if st.st_uid not in (me, 0):
            return f"is in {folder}, which belongs to another user (uid {st.st_uid})"
        if st.st_mode & (stat.S_IWGRP | stat.S_IWOTH) and not st.st_mode & stat.S_ISVTX:
            return (f"is in {folder}, which others can write (without the sticky bit, "
                    f"mode {stat.S_IMODE(st.st_mode):o})")
    return None


def _untrusted(path):
    """Why ``path`` is not a safe cache folder, or None if it is."""
    if not hasattr(os, "getuid"):
        return None  # no POSIX owners (Windows): the ACLs are the user's
    me = os.getuid()
    try:
        st = os.lstat(path)
    except OSError as err:
        return f"cannot be inspected ({err.strerror})"
    if stat.S_ISLNK(st.st_mode):
        return "is a symbolic link"
    if st.st_uid not in (me, 0):
        return f"belongs to another user (uid {st.st_uid})"
    if st.st_mode & (stat.S_IWGRP | stat.S_IWOTH):
        return f"is writable by group or others (mode {stat.S_IMODE(st.st_mode):o})"
    return _untrusted_ancestor(path)


def cache_decision():
    """(cache?, folder, reason): where numba would cache adaptid's kernels, and whether
    adaptid lets it (see the module docstring)."""
    candidates = []
    if os.environ.get("NUMBA_CACHE_DIR"):
        root = os.path.abspath(os.environ["NUMBA_CACHE_DIR"])
        candidates.append(os.path.join(root, _subpath(_KERNELS)))
    candidates.append(os.path.join(_KERNELS, "__pycache__"))
    candidates.append(os.path.join(_user_cache_root(), _subpath(_KERNELS)))
    for folder in candidates:
        if _usable(folder):
            why = _untrusted(folder)
            return (why is None), folder, (None if why is None else f"{folder} {why}")
    return False, None, "no writable cache folder (" + ", ".join(candidates) + ")"


CACHE, CACHE_DIR, _why = cache_decision()
if not CACHE:
    warnings.warn(f"adaptid: compiled kernels are not cached: {_why}; they are compiled "
                  "in every process (set NUMBA_CACHE_DIR to a private folder to cache them)",
                  CompilationCacheWarning, stacklevel=2)


def njit(*args, **options):
    """``numba.njit`` with adaptid's cache: a damaged cache entry is a miss, not an error.

    With ``cache=True`` the dispatcher's cache is enabled and handed to
    :data:`CACHE_HOOK` (set by :mod:`adaptid._kernels.toolchain._cache` when
    :mod:`adaptid._kernels` is imported: it makes a damaged index or code file
    a miss). Without the hook, or if numba's internals differ from what it
    expects, numba's own cache is kept unchanged.
    """
    import numba

    def wrap(fn):
        cache = options.get("cache", False)
        disp = numba.njit(**dict(options, cache=False))(fn)
        if cache and hasattr(disp, "enable_caching"):  # not under NUMBA_DISABLE_JIT=1
            disp.enable_caching()
            if CACHE_HOOK is not None:
                CACHE_HOOK(disp)
        return disp
    if args and callable(args[0]) and not options:
        return wrap(args[0])
    return wrap


#: ``hook(dispatcher)`` applied to every cached kernel's dispatcher, or None; set by
#: :func:`adaptid._kernels.toolchain._cache.install` (numba's internals stay there).
CACHE_HOOK = None


# fastmath={"contract"} lets LLVM fuse a*b + c into one FMA instruction (what
# gcc -O3 does for C by default) and nothing else: no reassociation, no
# assumption that values are finite, so NaN/inf checks and summation order stay
# as written. Results are deterministic on a given machine; on a CPU without FMA
# they differ in the last bits.

#: Options of every public kernel (compiled once, cached on disk if :data:`CACHE`).
NJIT = dict(cache=CACHE, nogil=True, fastmath={"contract"})
#: Options of kernels that run over independent streams in parallel.
NJIT_PARALLEL = dict(cache=CACHE, nogil=True, parallel=True, fastmath={"contract"})
#: Options of the small building blocks inlined into the kernels.
NJIT_INLINE = dict(cache=CACHE, inline="always", fastmath={"contract"})

#: Largest number of parameters for which kernels are specialised (n as a
#: compile-time constant, loops unrolled). Larger n use the generic kernels.
def _env_int(name: str, default: int) -> int:
    """An integer from the environment; a value that is none warns and gives ``default``."""
    text = os.environ.get(name)
    if text is None:
        return default
    try:
        return int(text)
    except ValueError:
        shown = text if len(text) <= 40 else text[:37] + "..."
        warnings.warn(f"adaptid: environment variable {name} must be an integer, got "
                      f"{shown!r}; using the default {default}", RuntimeWarning, stacklevel=2)
        return default


MAX_SPECIALISED_N = _env_int("ADAPTID_MAX_SPECIALISED_N", 16)

#: Removal of a sample from a sliding window is refused, and the window
#: re-solved from its buffer, when ``1 - c φᵀPφ`` (the ratio of the
#: determinants of the information matrix after and before the removal)
#: falls below this value: the downdate would cancel more than half the
#: digits in that direction.
DOWNDATE_RTOL = 1e-8

#: ``P0="diffuse"`` (exact diffuse start, :mod:`adaptid._kernels.recursions._diffuse`): RLS
#: and the sliding window treat θ as identified once the square-root
#: information factor R has σ_min(R) > DIFFUSE_RCOND · σ_max(R) (the weighted
#: Φ is then of full numerical rank; below it the minimum-norm solution drops
#: the smaller singular values, as ``numpy.linalg.lstsq(rcond=DIFFUSE_RCOND)``).
DIFFUSE_RCOND = 1e-10
#: The diffuse Kalman filter takes a sample as a rank step of P∞ when
#: F∞ = φᵀP∞φ > DIFFUSE_KALMAN_TOL · φᵀφ (P∞ starts as I; statsmodels uses an
#: absolute 1e-10 on F∞).
DIFFUSE_KALMAN_TOL = 1e-10
