r"""The engine every recursive estimator runs on.

One base class implements, once, what all recursive estimators share:
``update``, ``run``, ``run_batched``, ``run_segments``, ``predict``, the state
round trip (``get_state`` / ``from_state`` / state files), the NaN policy,
restoring the state when a call fails, and the numerical warnings. Its parts
live in modules named for what they hold, bound into the class by name:

* :mod:`._update` — ``update`` (the packed step and the run of length 1),
* :mod:`._runs` — ``run``, ``run_batched``, ``run_segments``,
* :mod:`._stateio` — ``get_state`` / ``from_state`` / state files / pickling,
* :mod:`._covariance` — ``P``, its U-D factors and ``excitation``,
* :mod:`._inputs` — the checks of samples, weights and forgetting,
* :mod:`._warn` — the numerical warnings from the kernels' return codes.

An algorithm (RLS, SlidingWindowRLS, KalmanRLS, LMS, NLMS) declares what it is
in one :class:`~._spec.AlgorithmSpec` (``spec``: its kernels, options, state
layout, which of the engine's features apply) and adds as code only the
``opt`` / ``mat`` its kernels read (:meth:`_kernel_options`), its forgetting
(:meth:`_lam_step`, :meth:`_lam_run`; :mod:`._forgetting`), filling and checking
its own state block (:meth:`_fill_initial`, :meth:`_check_state`,
:meth:`_fill_diffuse`) and its own warnings.
"""

from __future__ import annotations

import copy as _copy

import numpy as np

from .. import _kernels
from .._validation import as_float_array, check_choice, check_int, check_scalar, check_spd, \
    param_error
from . import _covariance, _inputs, _runs, _stateio, _update, _warn
from ._factor import ud_from_P
from ._hooks import upward as _upward
from ._inputs import NAN_POLICIES, strided

__all__ = ["RecursiveEstimator"]


class RecursiveEstimator:
    """Common engine; see :class:`~adaptid.RLS` and the other algorithms."""

    #: the algorithm's declaration (:class:`~._spec.AlgorithmSpec`), set by each class
    spec = None
    #: True while ``update`` / ``run`` / ``run_batched`` runs (:func:`._inputs.in_use`);
    #: a class attribute: never in an instance's dict, so a copy or a rebuilt state
    #: (``from_state``, pickling, the sqrt → U-D switch) never carries it
    _busy = False

    def _before_stats(self):
        """Called by a run with ``stats=True`` before its kernel (RLS: leave the
        square-root form for the U-D form, whose stream computes the statistics)."""

    def __init__(self, n_params, *, theta0=None, P0=1e4, nan_policy="raise",
                 n_outputs=None, windup_threshold=None):
        spec = self.spec
        n = check_int(n_params, "n_params", low=1)
        self._nan_policy = check_choice(nan_policy, "nan_policy", NAN_POLICIES)
        if n_outputs is not None:
            n_outputs = check_int(n_outputs, "n_outputs", low=1)
        if theta0 is None:
            p = n_outputs or 1
            th0 = np.zeros((n, p))
            single = n_outputs is None
        else:
            th0 = as_float_array(theta0, "theta0", ndim=(1, 2), copy=True)
            if th0.shape[0] != n:
                raise param_error("theta0", f"of length n_params={n}", f"<shape {th0.shape}>")
            single = th0.ndim == 1
            th0 = th0.reshape(n, -1)
            if n_outputs is not None and th0.shape[1] != n_outputs:
                raise param_error("theta0", f"of shape ({n}, {n_outputs}) for n_outputs={n_outputs}",
                                  f"<shape {th0.shape}>")
        self.n_params = n
        self.n_outputs = th0.shape[1]
        self._single = single
        self.theta0 = th0
        self._diffuse = False
        self._tail = 0  # the length of the diffuse tail of the state vector
        self._rebuilds = spec.rebuilds
        if not spec.covariance:
            self.P0 = None
            windup_threshold = np.inf  # nothing to wind up
        elif isinstance(P0, str):
            self._check_diffuse(P0, th0)
            self._diffuse = True
            self._tail = spec.diffuse_tail(n, self.n_outputs)
            self.P0 = "diffuse"
            self._U0, self._D0 = np.eye(n), np.ones(n)  # placeholders until identified
        else:
            self.P0 = check_spd(P0, "P0", n)
            self._U0, self._D0 = ud_from_P(self.P0)
        if windup_threshold is None:
            scale = 0.0 if self._diffuse else float(np.max(np.diag(self.P0)))
            Q = getattr(self, "process_cov", None)
            if Q is not None:
                scale = max(scale, float(np.max(np.diag(Q))))
            windup_threshold = 1e6 * scale if scale > 0 else np.inf
        self._windup_threshold = check_scalar(windup_threshold, "windup_threshold", low=0.0,
                                              low_open=True, finite=False)
        self._ybuf = np.empty(1)
        reports = spec.variant(self) in spec.reports_forgetting
        self._step = _update.StepArrays(n, self.n_outputs, reports or self._diffuse)
        self._ntag, self._ptag = _kernels.tags(n, self.n_outputs)
        self._sync_options()
        self.reset()

    def _check_diffuse(self, P0, th0):
        if P0 != "diffuse" or self.spec.diffuse_tail is None:
            raise param_error("P0", "a positive scalar, a symmetric positive definite (n, n) "
                              "matrix or 'diffuse'", P0)
        if np.any(th0 != 0.0):
            raise param_error("theta0", "None (zeros) with P0='diffuse' (a diffuse prior has "
                              "no mean)", "<nonzero values>")

    @property
    def diffuse(self) -> bool:
        """True for an exact diffuse start (``P0="diffuse"``)."""
        return self._diffuse

    def _fill_diffuse(self, T):
        """Initial diffuse tail (zeros: not identified, no information)."""

    def _identified_of(self, S):
        if not self._diffuse:
            return np.ones(S.shape[:-1], dtype=bool)
        return S[..., S.shape[-1] - self._tail] != 0.0

    @property
    def identified(self):
        r"""Whether the data determine θ (bool; (B,) after ``run_batched``).

        Always True with a finite prior ``P0``. With ``P0="diffuse"`` False
        until the (weighted, forgotten or windowed) information matrix
        :math:`\Phi^TW\Phi` has full numerical rank — θ is then the
        minimum-norm least-squares solution (RLS, window) or the diffuse
        Kalman filter's estimate, ``P`` is inf and :meth:`predict` NaN.
        """
        ident = self._identified_of(self._S)
        return bool(ident) if self._batch is None else ident

    # ------------------------------------------------ what an algorithm declares
    def _kernel_options(self):
        """(opt, mat): the float64 options vector (opt[0] the windup threshold) and matrix."""
        return np.array([self._windup_threshold]), np.zeros((1, 1))

    def _lam_step(self, forgetting):
        if forgetting is not None:
            raise param_error("forgetting", f"None for {type(self).__name__} (it has no "
                              "forgetting factor)", forgetting)
        return 1.0

    def _lam_run(self, forgetting, shape_N):
        self._lam_step(forgetting)
        return strided(np.broadcast_to(np.float64(1.0), shape_N))

    def _sync_options(self):
        """Read the options into what the kernels take (after a change of options)."""
        spec = self.spec
        self._update_ep = None
        self._lam_fixed = self._lam_step(None)
        self._opt, self._mat = self._kernel_options()
        self._variant = spec.variant(self)
        self._kern = spec.entries(self._variant)
        self._reports = self._variant in spec.reports_forgetting
        a = self._step
        a.step_ep = a.step_S = None  # looked up again by the next update
        a.R[a.ithr] = self._opt[0]

    @property
    def nan_policy(self) -> str:
        """What a sample with NaN or inf does: "raise" or "skip"."""
        return self._nan_policy

    @nan_policy.setter
    def nan_policy(self, value):
        self._nan_policy = check_choice(value, "nan_policy", NAN_POLICIES)
        self._sync_options()

    @property
    def windup_threshold(self) -> float:
        """A pivot of P = U D Uᵀ above it raises :class:`CovarianceWindupWarning`."""
        return self._windup_threshold

    @windup_threshold.setter
    def windup_threshold(self, value):
        self._windup_threshold = check_scalar(value, "windup_threshold", low=0.0,
                                              low_open=True, finite=False)
        self._sync_options()

    # ---------------------------------------------------------------- state
    def _state_length(self) -> int:
        """θ, the U-D factors of P (if any), the algorithm's own block, the diffuse tail."""
        n, p, spec = self.n_params, self.n_outputs, self.spec
        length = n * p + (n * n + n if spec.covariance else 0)
        if spec.buffer is not None:
            length += spec.buffer(self)
        return length + self._tail

    def _fill_initial(self, S):
        n, p = self.n_params, self.n_outputs
        S[: n * p] = self.theta0.ravel()
        if not self.spec.covariance:
            return
        S[n * p: n * p + n * n] = self._U0.T.ravel()  # U by columns (see adaptid._kernels)
        S[n * p + n * n: n * p + n * n + n] = self._D0
        if self._diffuse:
            self._fill_diffuse(S[S.shape[0] - self._tail:])

    def _check_state(self, S):
        """Refuse a state vector the kernels cannot run on safely (rows of S).

        RLS and Kalman states hold no indices: any float values are safe to
        run on (a wound-up state stays wound up). The window's are checked.
        """

    def reset(self):
        """Return to the prior (θ₀, P₀) and forget all data and any batch axis."""
        self._S = np.zeros(self._state_length())
        self._fill_initial(self._S)
        self._batch = None
        self.n_updates = 0
        self.n_skipped = 0
        self._windup_warned = False
        self._stats_acc = None
        return self

    def _theta_view(self, S):
        n, p = self.n_params, self.n_outputs
        th = S[..., : n * p].reshape(S.shape[:-1] + (n, p))
        return th[..., 0] if self._single else th

    @property
    def theta(self) -> np.ndarray:
        """Current estimate, shape (n,) or (n, p); (B, n[, p]) after ``run_batched``."""
        return self._theta_view(self._S).copy()

    @property
    def batch_size(self):
        """B after ``run_batched``, else None."""
        return self._batch

    def _check_single(self, what):
        if self._batch is not None:
            raise ValueError(
                f"{what} is for a single stream, but this estimator holds {self._batch} "
                "streams after run_batched; use run_batched, or reset() first")

    # ------------------------------------------------ the parts, bound by name
    # the covariance block of the state (._covariance)
    _no_covariance = _covariance.no_covariance
    _ud_views = _covariance.ud_views
    P = property(_covariance.P)
    _covariance_of = _covariance.covariance_of
    excitation = property(_covariance.excitation)
    # the checks of the input (._inputs)
    _phi = _inputs.check_phi
    _y = _inputs.check_y
    _weight = staticmethod(_inputs.check_weight)
    _nonfinite_step = _inputs.nonfinite_step
    _run_arrays = _inputs.run_arrays
    _per_sample = staticmethod(_inputs.per_sample)
    _in_use = _inputs.in_use
    # one sample (._update)
    update = _update.update
    compile_update = _update.compile_update
    _find_step = _update.find_step
    _step_kernel = _update.step_kernel
    _skipped_step = _update.skipped_step
    # N samples, B streams, G segments (._runs)
    run = _runs.run
    run_batched = _runs.run_batched
    run_segments = _runs.run_segments
    _soa_entry = _runs.soa_entry
    _raise_if_skipped = _runs.raise_if_skipped
    _backup = _runs.backup
    _prepare_batch = _runs.prepare_batch
    _finish = _runs.finish
    _alloc = _runs.alloc
    _count = _runs.count
    # the numerical warnings (._warn)
    _warn_nonpositive = _warn.warn_nonpositive
    _warn_rebuild = _warn.warn_rebuild
    _check_pivots = _warn.check_pivots
    _report_codes = _warn.report_codes
    _code_warnings = _warn.code_warnings
    _warn_segments = _warn.warn_segments
    # the state round trip (._stateio)
    _options = _stateio.options
    get_state = _stateio.get_state
    kernel_settings = _stateio.kernel_settings
    from_state = classmethod(_stateio.from_state)
    _set_state = _stateio.set_state
    save_state = _stateio.save_state
    load_state = classmethod(_stateio.load_state)
    __getstate__ = _stateio.getstate
    __setstate__ = _stateio.setstate

    # ------------------------------------------------------------ prediction
    def predict(self, phi):
        r"""Predicted output :math:`\hat y = \varphi^T\hat\theta`.

        Parameters
        ----------
        phi : array_like, shape (n,) or (N, n); (B, n) or (B, N, n) when batched

        Returns
        -------
        float or ndarray
            Shape (), (N,) [or with a trailing p axis for several outputs].
        """
        n = self.n_params
        theta = self._theta_view(self._S)
        if self._diffuse and not self._identified_of(self._S).all():
            theta = np.where(self._identified_of(self._S).reshape(
                self._S.shape[:-1] + (1,) * (theta.ndim - self._S.ndim + 1)), theta, np.nan)
        if self._batch is None:
            phi = as_float_array(phi, "phi", ndim=(1, 2))
            if phi.shape[-1] != n:
                raise param_error("phi", f"of shape (n,) or (N, n) with n={n}", f"<shape {phi.shape}>")
            with np.errstate(over="ignore", invalid="ignore"):  # huge φ: inf, as NumPy gives
                out = phi @ theta
            return float(out) if out.ndim == 0 else out
        phi = as_float_array(phi, "phi", ndim=(2, 3))
        if phi.shape[0] != self._batch or phi.shape[-1] != n:
            raise param_error("phi", f"of shape (B, n) or (B, N, n) with B={self._batch}, n={n}",
                              f"<shape {phi.shape}>")
        with np.errstate(over="ignore", invalid="ignore"):
            if self._single:
                return np.einsum("b...i,bi->b...", phi, theta)
            return np.einsum("b...i,bij->b...j", phi, theta)

    # ---------------------------------------------------------------- export
    def to_c(self, directory, *, name="rls", dtype="float64"):
        r"""Write ``NAME.h`` and ``NAME.c``: this estimator's recursion in C99, from its state.

        The generated update continues exactly where this estimator stands
        (bit for bit with ``-DNAME_USE_FMA`` on a CPU with FMA). See
        :func:`adaptid.codegen.to_c` for the generated interface, the
        supported options and the verification, and ``docs/embedded.md``.

        Parameters
        ----------
        directory : str or os.PathLike
        name : str
            C identifier: file names and the prefix of every symbol.
        dtype : {"float64", "float32"}

        Returns
        -------
        tuple of pathlib.Path
            The header and the source file.
        """
        return _upward("adaptid.codegen").to_c(self, directory, name=name, dtype=dtype)

    def copy(self):
        """An independent deep copy."""
        return _copy.deepcopy(self)

    def __repr__(self):
        opts = ", ".join(f"{k}={v!r}" for k, v in self._options().items() if k != "nan_policy")
        batch = f", batch={self._batch}" if self._batch is not None else ""
        return (f"{type(self).__name__}(n_params={self.n_params}"
                f"{', n_outputs=' + str(self.n_outputs) if not self._single else ''}"
                f"{', ' + opts if opts else ''}, n_updates={self.n_updates}{batch})")
