r"""What an algorithm declares to the engine: one :class:`AlgorithmSpec` per class.

Each recursive estimator class states, in one frozen object ``spec``, what the
engine (:mod:`._engine`) needs to know of it instead of a set of boolean class
flags::

    class SlidingWindowRLS(ForgettingMixin, RecursiveEstimator):
        spec = AlgorithmSpec(
            method="window",
            kernels={"default": "WINDOW", "diffuse": "WINDOW_DIFFUSE"},
            options=("window", "forgetting", "nan_policy", "windup_threshold"),
            diffuse_tail=lambda n, p: 2,
            buffer=lambda est: ...,
            rebuilds=True, stats=("default", "diffuse"), stats_from_buffer=True)

A *variant* names the kernels an estimator runs on for its options (RLS:
``"ud"``, ``"sqrt"``, ``"covariance"``, ``"strategy"`` or ``"diffuse"``); the
engine resolves it once per change of options (``RecursiveEstimator._sync_options``)
and reads the variant's entries and flags from here. What stays code in the
class: the options vector of the kernels (``_kernel_options``), the forgetting
(``_lam_step`` / ``_lam_run``), filling and checking its own state block
(``_fill_initial``, ``_check_state``) and its own warnings.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable, Mapping

__all__ = ["AlgorithmSpec", "default_variant"]


def default_variant(est) -> str:
    """``"diffuse"`` for an exact diffuse start (``P0="diffuse"``), else ``"default"``."""
    return "diffuse" if est._diffuse else "default"


@dataclass(frozen=True)
class AlgorithmSpec:
    """The declaration of a recursive algorithm (read by the engine, never changed).

    Parameters
    ----------
    method : str
        Its name for :func:`adaptid.estimator` (and ``KernelSettings.method``).
    kernels : mapping of str to str
        Variant -> name of its :class:`adaptid._kernels.Entries` in
        :mod:`adaptid._kernels` (e.g. ``"RLS"`` for ``adaptid._kernels.RLS``),
        looked up when an estimator is built (the kernels load lazily).
    options : tuple of str
        The options of ``get_state()["options"]`` in order: each is read as the
        estimator's attribute of that name (an array copied, a forgetting
        strategy as its ``to_dict()``).
    variant : callable, optional
        ``variant(est) -> str``, a key of ``kernels``; default
        :func:`default_variant`.
    covariance : bool
        The state holds the U-D factors of a covariance P after θ (False: θ
        only — the gradient estimators: no ``P0``, ``P``, ``excitation`` or
        windup watch).
    diffuse_tail : callable or None
        ``diffuse_tail(n, p) -> int``: the length of the state's tail that an
        exact diffuse start (``P0="diffuse"``) adds; None: no diffuse start.
    buffer : callable or None
        ``buffer(est) -> int``: the length of the algorithm's own block after
        θ and the covariance factors (the window's second factors and its
        buffer); None: none.
    rebuilds : bool
        The kernel's return code counts re-solves of the window (else: the
        first bad sample, or −1); the engine checks the pivots after each call.
    reports_forgetting : tuple of str
        The variants whose kernels report the forgetting factor applied per
        sample (the forgetting strategies): ``Trajectory.forgetting``.
    stats : tuple of str
        The variants that compute windowed statistics, ``run(stats=True)``
        (see :mod:`._windowstats`).
    stats_from_buffer : bool
        The kernel sums its own buffer for the statistics (else a run continues
        the sums of the previous one).
    """

    method: str
    kernels: Mapping[str, str]
    options: tuple
    variant: Callable = default_variant
    covariance: bool = True
    diffuse_tail: Callable | None = None
    buffer: Callable | None = None
    rebuilds: bool = False
    reports_forgetting: tuple = ()
    stats: tuple = ()
    stats_from_buffer: bool = False

    def entries(self, variant):
        """The compiled entry points of ``variant`` (:class:`adaptid._kernels.Entries`)."""
        from .. import _kernels
        return getattr(_kernels, self.kernels[variant])
