"""``adaptid.estimator``: the one map from a method name to an estimator.

The command line (``--method``), the fleet (``method=``), the scikit-learn
face (``RLSRegressor(method=)``) and the models' recursive fits all call
:func:`estimator`, so a method name means the same estimator everywhere.
"""

from __future__ import annotations

from .._validation import check_choice, check_int, param_error

__all__ = ["estimator", "METHODS", "method_of", "method_options", "required_options"]

#: Method names and the keyword options each one takes (besides the common
#: ``theta0``, ``P0``, ``nan_policy``, ``n_outputs``, ``windup_threshold``).
_SPECIFIC = {
    "rls": ("forgetting", "P_max", "form"),
    "window": ("window", "forgetting"),
    "kalman": ("process_cov", "noise_var"),
    "lms": ("step",),
    "nlms": ("step", "eps"),
}
_REQUIRED = {"window": ("window",), "kalman": ("process_cov",), "lms": ("step",),
             "nlms": ("step",)}
_COMMON = ("theta0", "P0", "nan_policy", "n_outputs", "windup_threshold")
#: the gradient methods keep no covariance: no P0, no windup threshold
_GRADIENT = ("lms", "nlms")
_COMMON_GRADIENT = ("theta0", "nan_policy", "n_outputs")
_CLASSES = {"rls": "RLS", "window": "SlidingWindowRLS", "kalman": "KalmanRLS", "lms": "LMS",
            "nlms": "NLMS"}

#: The method names, in the order the documentation lists them.
METHODS = tuple(_SPECIFIC)


def method_options(method: str) -> tuple[str, ...]:
    """The keyword options :func:`estimator` accepts for ``method``."""
    method = check_choice(method, "method", METHODS)
    return _SPECIFIC[method] + (_COMMON_GRADIENT if method in _GRADIENT else _COMMON)


def required_options(method: str) -> tuple[str, ...]:
    """The keyword options :func:`estimator` needs for ``method`` (no default)."""
    method = check_choice(method, "method", METHODS)
    return _REQUIRED.get(method, ())


def _classes():
    from ._kalman import KalmanRLS
    from ._lms import LMS, NLMS
    from ._rls import RLS
    from ._window import SlidingWindowRLS
    return {"rls": RLS, "window": SlidingWindowRLS, "kalman": KalmanRLS, "lms": LMS,
            "nlms": NLMS}


def method_of(est) -> str:
    """The method name of an estimator made by :func:`estimator` (its inverse)."""
    name = getattr(getattr(type(est), "spec", None), "method", None)
    if name in _CLASSES and type(est).__name__ == _CLASSES[name]:
        return name
    raise param_error("estimator", f"an estimator of one of the methods {', '.join(METHODS)}",
                      est, exc=TypeError)


def estimator(method, n_params, **options):
    r"""A recursive estimator from its method name.

    Parameters
    ----------
    method : {"rls", "window", "kalman", "lms", "nlms"}
        ``"rls"``: :class:`~adaptid.RLS` (exponential forgetting or a
        strategy of :mod:`adaptid.forgetting`, ``P_max``);
        ``"window"``: :class:`~adaptid.SlidingWindowRLS` (needs ``window``);
        ``"kalman"``: :class:`~adaptid.KalmanRLS` (needs ``process_cov``);
        ``"lms"``: :class:`~adaptid.LMS` (needs ``step``);
        ``"nlms"``: :class:`~adaptid.NLMS` (needs ``step``; ``eps``).
    n_params : int
        Number of parameters n.
    **options
        The estimator's keyword options: ``theta0``, ``nan_policy``,
        ``n_outputs`` for every method, ``P0``, ``windup_threshold`` for the
        least-squares ones (not lms / nlms: no covariance), and
        ``forgetting``, ``P_max`` (rls), ``window``, ``forgetting`` (window),
        ``process_cov``, ``noise_var`` (kalman), ``step`` (lms), ``step``,
        ``eps`` (nlms).

    Returns
    -------
    RLS, SlidingWindowRLS, KalmanRLS, LMS or NLMS

    Raises
    ------
    ValueError
        An unknown method, or an option value out of range.
    TypeError
        An option the method does not take, or a required one missing.

    Examples
    --------
    >>> import adaptid
    >>> adaptid.estimator("window", 3, window=50, forgetting=0.99)
    SlidingWindowRLS(n_params=3, window=50, forgetting=0.99, windup_threshold=10000000000.0, n_updates=0)
    """
    method = check_choice(method, "method", METHODS)
    n = check_int(n_params, "n_params", low=1)
    allowed = method_options(method)
    for key in options:
        if key not in allowed:
            raise param_error(key, f"an option of method={method!r} ({', '.join(allowed)})",
                              "<an unknown option>", exc=TypeError)
    for key in required_options(method):
        if options.get(key) is None:
            raise param_error(key, f"given for method={method!r}", "<None>", exc=TypeError)
    opts = dict(options)
    cls = _classes()[method]
    if method == "window":
        return cls(n, opts.pop("window"), **opts)
    return cls(n, **opts)
