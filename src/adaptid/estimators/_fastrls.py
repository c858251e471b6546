r"""Fast RLS for a tapped delay line: O(n) per sample (issue 38).

:class:`FastRLS` is not built on the engine of :mod:`._engine`: its regressor
is the last n samples of one input, so its state is predictors and a gain, not
a covariance. It has the engine's method names and result types (``update``,
``run``, ``run_batched``, ``predict``, ``reset``, ``copy``, ``get_state`` /
``from_state``, ``save_state`` / ``load_state``, :class:`Trajectory`).
"""

from __future__ import annotations

import types

import numpy as np

from .._exceptions import StateFileError
from .._kernels.recursions._parallel import parallel_guard
from .._validation import as_float_array, check_choice, check_int, check_scalar, param_error
from . import _statefile
from ._fastlayout import METHODS, layout as _layout
from ._inputs import exclusive
from ._trajectory import Trajectory

__all__ = ["FastRLS"]

#: Error-feedback gains (K1, K2, K3) of Slock & Kailath (1991), sect. IV: the
#: values their analysis shows stable for λ ≥ 1 − 1/(2n).
FEEDBACK = (1.5, 2.5, 1.0)
#: A rescue happens when the conversion factor γ exceeds 1 + GAMMA_TOL (in exact
#: arithmetic 0 < γ ≤ 1; rounding of φᵀk̃ ≈ 0 may exceed 1 by a few ulps).
GAMMA_TOL = 1e-8
NAN_POLICIES = ("raise", "skip")


class FastRLS:
    r"""Exponentially weighted RLS of a transversal (FIR) filter in O(n) per sample.

    For regressors that are a prewindowed tapped delay line of one input,
    :math:`\varphi_k = [u_k, u_{k-1}, \dots, u_{k-n+1}]^T` with
    :math:`u_j = 0` for :math:`j < 1`, θ after sample N minimises

    .. math::

        \sum_{k=1}^{N}\lambda^{N-k}(y_k - \varphi_k^T\theta)^2
        + \delta\sum_{i=0}^{n-1}\lambda^{N-i}(\theta_i - \theta_{0,i})^2,

    i.e. it equals :class:`adaptid.RLS` with ``forgetting=λ`` and
    ``P0=np.diag(λ**np.arange(n)) / δ`` on the same regressors (the soft
    start a fast filter realises: an input pulse of energy δλ⁻ⁿ just before
    the record; with λ = 1 it is ``P0 = 1/δ``), to rounding level, with
    O(n) operations per sample instead of O(n²).

    ``method="ftf"`` is the stabilised fast transversal filter (Slock &
    Kailath 1991, Table I and sect. IV; Diniz, *Adaptive Filtering*, 4th ed.,
    Algorithm 8.2): forward and backward predictors of order n, the backward
    a-priori error computed twice (directly and from the gain) and mixed with
    the feedback gains K1 = 1.5, K2 = 2.5, K3 = 1, the conversion factor γ
    recomputed from the gain. Exact in its stable range λ ≥ 1 − 1/(2n);
    outside it, and whenever γ leaves (0, 1] or an energy is not positive, a
    *rescue* re-initialises the predictors at the soft start (energy the
    mean square of the delay line, at least δ), keeping θ; ``n_rescues``
    counts them, and θ is then no longer the exact minimiser above.

    ``method="lattice"`` is the QR-decomposition least-squares lattice
    (Regalia & Bellanger 1991; Proudler, McWhirter & Shepherd 1988; the
    algorithm of SLICOT FD01AD, whose published example it reproduces):
    Givens rotations only, numerically robust for λ < 1, O(n) per sample for
    the a-priori errors. It holds the parameters of the equivalent normalised
    lattice, not θ; with ``track_theta=True`` (the default) θ is read after
    every sample from the square-root information array of the same problem,
    updated by Givens rotations and solved by back substitution
    (:math:`R_k\theta_k = z_k`, McWhirter 1983), which costs O(n²) per
    sample. ``track_theta=False`` keeps the lattice O(n) and gives the
    a-priori errors only (``theta`` then raises). The lattice has no rescue.

    The recursions are in :mod:`adaptid._kernels.recursions._fastrls`.

    Parameters
    ----------
    n_taps : int
        Number of taps n (parameters), ≥ 1.
    forgetting : float
        λ ∈ (0, 1].
    delta : float
        δ > 0, the soft-start regularisation (the forward prediction-error
        energy starts at δ, the backward one at δλ⁻ⁿ).
    method : {"ftf", "lattice"}
        The fast algorithm.
    nan_policy : {"raise", "skip"}
        A sample with a non-finite value raises, or is skipped: it is not
        shifted into the delay line and the state is untouched.
    theta0 : array_like, shape (n,), optional
        The prior mean θ₀ (zeros by default).
    track_theta : bool
        Lattice only: keep θ (O(n²) per sample) or not (O(n), errors only).
        The FTF always holds θ.

    Attributes
    ----------
    theta : ndarray, shape (n,) or (B, n)
        The current estimate (B after :meth:`run_batched`).
    delay_line : ndarray, shape (n,) or (B, n)
        The current regressor :math:`\varphi_k`.
    n_updates, n_skipped : int
        Samples used and samples skipped (summed over the streams when batched).
    n_rescues : int or ndarray of int, shape (B,)
        Rescues of the FTF (per stream when batched).

    References
    ----------
    D. T. M. Slock and T. Kailath, "Numerically stable fast transversal
    filters for recursive least squares adaptive filtering", IEEE Trans.
    Signal Process. 39(1), 92-114, 1991. doi:10.1109/78.80769.
    J. M. Cioffi and T. Kailath, "Fast, recursive-least-squares transversal
    filters for adaptive filtering", IEEE Trans. ASSP 32(2), 304-337, 1984.
    P. A. Regalia and M. G. Bellanger, "On the duality between fast QR
    methods and lattice methods in least squares adaptive filtering", IEEE
    Trans. Signal Process. 39(4), 879-891, 1991.
    J. G. McWhirter, "Recursive least-squares minimization using a systolic
    array", Proc. SPIE 431, 105-112, 1983.
    SLICOT FD01AD (P. A. Regalia, 1994), https://github.com/SLICOT/SLICOT-Reference.

    Examples
    --------
    >>> import numpy as np
    >>> import adaptid
    >>> rng = np.random.default_rng(0)
    >>> u = rng.standard_normal(500)
    >>> y = np.convolve(u, [0.5, -0.3, 0.2])[:500]
    >>> est = adaptid.FastRLS(3, forgetting=0.99, delta=1e-3)
    >>> traj = est.run_fir(u, y)
    >>> np.round(est.theta, 6)
    array([ 0.5, -0.3,  0.2])
    """

    #: True while a run of the kernels is under way (:func:`._inputs.in_use`: an estimator
    #: is not thread-safe; a second call meanwhile raises RuntimeError)
    _busy = False
    spec = types.SimpleNamespace(method="fastrls", covariance=False,
                                 options=("forgetting", "delta", "method", "nan_policy",
                                          "track_theta"))

    def __init__(self, n_taps, *, forgetting=1.0, delta=1e-4, method="ftf",
                 nan_policy="raise", theta0=None, track_theta=True):
        self.n_taps = check_int(n_taps, "n_taps", low=1)
        self.forgetting = check_scalar(forgetting, "forgetting", low=0.0, high=1.0,
                                       low_open=True)
        self.delta = check_scalar(delta, "delta", low=0.0, low_open=True)
        if not np.isfinite(self.delta * self.forgetting ** (-float(self.n_taps))):
            raise param_error("delta", f"small enough that δλ⁻ⁿ is finite (λ={self.forgetting:g}, "
                              f"n={self.n_taps})", delta)
        self.method = check_choice(method, "method", METHODS)
        self.nan_policy = check_choice(nan_policy, "nan_policy", NAN_POLICIES)
        if not isinstance(track_theta, (bool, np.bool_)):
            raise param_error("track_theta", "True or False", track_theta, exc=TypeError)
        self.track_theta = bool(track_theta) or self.method == "ftf"
        n = self.n_taps
        self.theta0 = (np.zeros(n) if theta0 is None
                       else as_float_array(theta0, "theta0", shape=(n,), copy=True))
        self.reset()

    # ---------------------------------------------------------------- state
    @property
    def n_params(self) -> int:
        """Number of parameters (= ``n_taps``)."""
        return self.n_taps

    def _length(self) -> int:
        return _layout(self.method, self.n_taps, self.track_theta)

    def _initial_state(self) -> np.ndarray:
        n, lam, d = self.n_taps, self.forgetting, self.delta
        S = np.zeros(self._length())
        S[:n] = self.theta0
        if self.method == "ftf":
            S[5 * n: 5 * n + 3] = d, d * lam ** (-n), 1.0
            return S
        S[3 * n] = 1.0                      # sqrt of the conversion factor
        S[3 * n + 1: 4 * n + 1] = 1.0       # cosines
        S[7 * n + 1] = np.sqrt(d)           # sqrt of the forward energy
        if self.track_theta:                # R0 = diag(sqrt(δ λ^-i)), z0 = R0 θ0
            r0 = np.sqrt(d * lam ** (-np.arange(n, dtype=np.float64)))
            S[7 * n + 2: 7 * n + 2 + n * n] = np.diag(r0).ravel()
            S[7 * n + 2 + n * n:] = r0 * self.theta0
        return S

    def reset(self):
        """Back to the soft start: θ = θ₀, empty (zero) delay line, no counts."""
        self._S = self._initial_state()
        self._rescues = 0
        self._batch = None
        self.n_updates = 0
        self.n_skipped = 0

    @property
    def theta(self) -> np.ndarray:
        """The current estimate θ, shape (n,) or (B, n) (a copy)."""
        if not self.track_theta:
            raise ValueError("theta is not tracked: this lattice was made with "
                             "track_theta=False (a-priori errors only)")
        return self._S[..., : self.n_taps].copy()

    @property
    def delay_line(self) -> np.ndarray:
        """The current regressor [u_k, ..., u_(k-n+1)], shape (n,) or (B, n) (a copy)."""
        at = self._line_at()
        return self._S[..., at: at + self.n_taps].copy()

    def _line_at(self) -> int:
        return 4 * self.n_taps if self.method == "ftf" else 6 * self.n_taps + 1

    @property
    def n_rescues(self):
        """Rescues of the FTF so far (per stream after :meth:`run_batched`)."""
        return self._rescues.copy() if self._batch is not None else int(self._rescues)

    def _opt(self) -> np.ndarray:
        if self.method == "lattice":
            return np.array([self.forgetting, self.delta, float(self.track_theta)])
        return np.array([self.forgetting, self.delta, *FEEDBACK, 1.0, GAMMA_TOL])

    def copy(self) -> "FastRLS":
        """An independent copy (same options and state)."""
        return type(self).from_state(self.get_state())

    def __repr__(self):
        return (f"FastRLS({self.n_taps}, forgetting={self.forgetting!r}, delta={self.delta!r}, "
                f"method={self.method!r})")

    # ---------------------------------------------------------------- samples
    def update(self, phi, y, *, weight=1.0) -> float:
        r"""Process one sample; returns the a-priori error :math:`y - \varphi^T\theta`.

        Parameters
        ----------
        phi : array_like, shape (n,)
            The full regressor. ``phi[0]`` is the new input sample
            :math:`u_k`; ``phi[1:]`` must equal the current delay line
            without its oldest sample (``delay_line[:-1]``): the line is
            shifted by one, so anything else is refused with a ValueError.
        y : float
            The output :math:`y_k`.
        weight : float
            Must be 1 (a fast filter has no per-sample weights).
        """
        self._check_single("update")
        if weight != 1.0:
            raise param_error("weight", "1.0 (FastRLS has no sample weights)", weight)
        phi = as_float_array(phi, "phi", shape=(self.n_taps,), finite=False)
        yv = check_scalar(y, "y", finite=False) if np.ndim(y) == 0 else \
            as_float_array(y, "y", shape=(1,), finite=False)[0]
        good = bool(np.isfinite(phi).all() and np.isfinite(yv))
        if not good and self.nan_policy == "raise":
            raise param_error("phi and y", "finite (no NaN or inf) with nan_policy='raise'",
                              "<a non-finite value>")
        if good:
            _check_line(phi[None, :], np.ones(1, bool), self.delay_line, "phi")
        traj = self._run(np.array([phi[0] if good else np.nan]), np.array([yv]), True,
                         "update")
        return float(traj.error[0])

    def predict(self, phi):
        r"""The prediction :math:`\varphi^T\theta` for a regressor (n,) or rows (N, n)."""
        phi = as_float_array(phi, "phi", ndim=(1, 2))
        if phi.shape[-1] != self.n_taps:
            raise param_error("phi", f"of length {self.n_taps} in its last axis",
                              f"<shape {phi.shape}>")
        return phi @ self.theta.T

    def run(self, Phi, y, *, store_theta=True) -> Trajectory:
        """Process N samples given as regressor rows (a tapped delay line).

        Parameters
        ----------
        Phi : array_like, shape (N, n)
            Row k is :math:`[u_k, u_{k-1}, \\dots, u_{k-n+1}]`, continuing the
            current delay line (a fresh estimator: zeros before the first
            row). Checked exactly; a row that is not the previous one shifted
            by one sample raises a ValueError naming it.
        y : array_like, shape (N,)
        store_theta : bool
            Keep θ after every sample (``Trajectory.theta``, N × n); False
            gives an empty one (the cost then stays O(n) per sample in memory).

        Returns
        -------
        Trajectory
            ``theta`` (N, n), ``error`` (a-priori errors), ``skipped``;
            ``meta["n_rescues"]`` the rescues during this run.
        """
        self._check_single("run")
        Phi, y, good = self._rows(Phi, y)
        _check_line(Phi, good, self.delay_line, "Phi")
        u = np.where(good, Phi[:, 0] if Phi.shape[0] else 0.0, np.nan)
        return self._run(u, np.where(good, y, np.nan), store_theta)

    def run_fir(self, u, y, *, store_theta=True) -> Trajectory:
        """Process N samples of the input u and output y directly.

        Parameters
        ----------
        u, y : array_like, shape (N,), or (B, N) for B independent streams
            (as :meth:`run_batched`).
        store_theta : bool
            As in :meth:`run`.
        """
        u = as_float_array(u, "u", ndim=(1, 2), finite=self.nan_policy == "raise")
        y = as_float_array(y, "y", shape=u.shape, finite=self.nan_policy == "raise")
        if u.ndim == 2:
            return self._run_batched(u, y, store_theta)
        self._check_single("run_fir")
        return self._run(u, y, store_theta, "run_fir")

    def run_batched(self, Phi, y, *, store_theta=True) -> Trajectory:
        """B independent streams in one compiled, parallel call.

        ``Phi`` (B, N, n) delay lines, ``y`` (B, N). Every stream starts from
        the current state (a single state is copied to all B); afterwards
        ``theta``, ``delay_line`` and ``n_rescues`` carry the leading axis B.
        """
        Phi = as_float_array(Phi, "Phi", ndim=3, finite=self.nan_policy == "raise")
        if Phi.shape[2] != self.n_taps:
            raise param_error("Phi", f"of shape (B, N, {self.n_taps})", f"<shape {Phi.shape}>")
        y = as_float_array(y, "y", shape=Phi.shape[:2], finite=self.nan_policy == "raise")
        good = np.isfinite(Phi).all(axis=2) & np.isfinite(y)
        at, n = self._line_at(), self.n_taps
        lines = self._start_states(Phi.shape[0])[:, at: at + n]
        for b in range(Phi.shape[0]):
            _check_line(Phi[b], good[b], lines[b], f"Phi[{b}]")
        u = np.where(good, Phi[:, :, 0] if Phi.shape[1] else 0.0, np.nan)
        return self._run_batched(u, np.where(good, y, np.nan), store_theta)

    # ---------------------------------------------------------------- internals
    def _check_single(self, what):
        if self._batch is not None:
            raise ValueError(f"{what} needs a single-stream FastRLS; this one holds "
                             f"{self._batch} streams after run_batched (reset() it)")

    def _rows(self, Phi, y):
        finite = self.nan_policy == "raise"
        Phi = as_float_array(Phi, "Phi", shape=(None, self.n_taps), finite=finite)
        y = as_float_array(y, "y", shape=(Phi.shape[0],), finite=finite)
        return Phi, y, np.isfinite(Phi).all(axis=1) & np.isfinite(y)

    def _kernels(self):
        """(run, run_batched), each taking (S, u, y, opt, Th, E, skipped[, rescues])."""
        from .._kernels.recursions import _fastrls as K
        if self.method == "ftf":
            return K.ftf_run, K.ftf_run_batched
        th0 = self.theta0

        def run(S, u, y, opt, Th, E, skipped):
            return K.lattice_run(S, u, y, opt, th0, Th, E, skipped)

        def run_batched(S, U, Y, opt, Th, E, skipped, rescues):
            K.lattice_run_batched(S, U, Y, opt, th0, Th, E, skipped, rescues)
        return run, run_batched

    def _run(self, u, y, store_theta, what="run") -> Trajectory:
        with exclusive(self, what):
            return self._run_one(u, y, store_theta)

    def _run_one(self, u, y, store_theta) -> Trajectory:
        run, _ = self._kernels()
        N, n = u.shape[0], self.n_taps
        S = self._S.copy()  # the state changes only if the kernel returns
        Th = np.empty((N if store_theta and self.track_theta else 0, n))
        E = np.empty(N)
        skipped = np.zeros(N, dtype=np.bool_)
        try:
            r = run(S, np.ascontiguousarray(u), np.ascontiguousarray(y), self._opt(), Th, E,
                    skipped)
        except ZeroDivisionError:  # the lattice's energies overflowed to inf (then inf/inf)
            raise _overflow_error() from None
        _warn_overflow(E, skipped)
        self._S = S
        self._rescues += r
        k = int(np.count_nonzero(skipped))
        self.n_skipped += k
        self.n_updates += N - k
        return Trajectory(theta=Th, error=E, skipped=skipped, meta={"n_rescues": int(r)})

    def _start_states(self, B):
        if self._batch is None:
            return np.tile(self._S, (B, 1))
        if self._batch != B:
            raise param_error("Phi", f"{self._batch} streams (the estimator's batch)",
                              f"<{B} streams>")
        return self._S.copy()

    def _run_batched(self, u, y, store_theta) -> Trajectory:
        with exclusive(self, "run_batched"):
            return self._run_many(u, y, store_theta)

    def _run_many(self, u, y, store_theta) -> Trajectory:
        _, run_batched = self._kernels()
        B, N = u.shape
        S = self._start_states(B)
        Th = np.empty((B, N if store_theta and self.track_theta else 0, self.n_taps))
        E = np.empty((B, N))
        skipped = np.zeros((B, N), dtype=np.bool_)
        r = np.zeros(B, dtype=np.int64)
        with parallel_guard():  # the workqueue layer: one parallel call at a time
            try:
                run_batched(S, np.ascontiguousarray(u), np.ascontiguousarray(y), self._opt(),
                            Th, E, skipped, r)
            except ZeroDivisionError:
                raise _overflow_error() from None
        _warn_overflow(E, skipped)
        if self._batch is None:
            self._rescues = np.full(B, self._rescues, dtype=np.int64)
        self._S, self._batch = S, B
        self._rescues = self._rescues + r
        k = int(np.count_nonzero(skipped))
        self.n_skipped += k
        self.n_updates += B * N - k
        return Trajectory(theta=Th, error=E, skipped=skipped, meta={"n_rescues": r})

    # ---------------------------------------------------------------- state round trip
    def get_state(self) -> dict:
        """Everything needed to resume exactly (plain values and float64 arrays)."""
        rescues = np.asarray(self._rescues, dtype=np.float64)[..., None]
        return {
            "estimator": "FastRLS", "format": _statefile.FORMAT, "n_params": self.n_taps,
            "n_outputs": 1, "single_output": True,
            "options": {name: getattr(self, name) for name in self.spec.options},
            "theta0": self.theta0[:, None].copy(), "P0": None,
            "state": np.concatenate([self._S, rescues], axis=-1),
            "batch": self._batch,
            "n_updates": self.n_updates, "n_skipped": self.n_skipped,
        }

    @classmethod
    def from_state(cls, state: dict) -> "FastRLS":
        """Rebuild a FastRLS from :meth:`get_state`'s dict (exact round trip)."""
        if not isinstance(state, dict):
            raise param_error("state", "a dict from get_state()", state, exc=TypeError)
        try:
            if state["estimator"] != "FastRLS":
                raise param_error("state", "the state of a FastRLS",
                                  f"<the state of a {state['estimator']}>")
            if state["format"] != _statefile.FORMAT:
                raise param_error("state['format']", f"{_statefile.FORMAT}", state["format"])
            theta0 = np.asarray(state["theta0"], dtype=np.float64).reshape(-1)
            est = cls(int(state["n_params"]), theta0=theta0, **dict(state["options"]))
            est._set_state(state["state"], state["batch"], state["n_updates"],
                           state["n_skipped"])
        except (KeyError, TypeError, AttributeError) as err:
            raise param_error("state", "a complete dict from FastRLS.get_state()",
                              f"<{type(err).__name__}: {err}>") from None
        return est

    def _set_state(self, S, batch, n_updates, n_skipped):
        L = self._length() + 1
        S = as_float_array(S, "state['state']", shape=(L,) if batch is None else (batch, L),
                           copy=True)
        n = self.n_taps
        T = S.reshape(-1, L)
        r = T[:, -1]
        if self.method == "ftf":
            a, b, g = T[:, 5 * n], T[:, 5 * n + 1], T[:, 5 * n + 2]
        else:  # sqrt of the forward energy, and of the conversion factor
            a, g = T[:, 7 * n + 1], T[:, 3 * n]
            b = a
        if not (np.all(a > 0) and np.all(b > 0) and np.all((g > 0) & (g <= 1 + GAMMA_TOL))
                and np.all((r >= 0) & (r == np.round(r)))):
            raise param_error("state['state']", "a FastRLS state (energies > 0, 0 < γ ≤ 1, "
                              "a whole rescue count ≥ 0)", "<values no FastRLS holds>")
        self._S = np.ascontiguousarray(S[..., :-1])
        self._batch = None if batch is None else int(batch)
        self._rescues = int(r[0]) if batch is None else r.astype(np.int64)
        self.n_updates, self.n_skipped = int(n_updates), int(n_skipped)

    def save_state(self, path):
        """Write the state to ``path`` (versioned, checksummed ``.npz``; never pickle).

        The container of :func:`adaptid.save_state`: written to a temporary
        name and renamed; read back with :meth:`load_state` or
        :func:`adaptid.load_state`.
        """
        _statefile.save_state(self, path)

    @classmethod
    def load_state(cls, path) -> "FastRLS":
        """Read a file written by :meth:`save_state`; StateFileError if damaged or foreign."""
        est = _statefile.load_state(path)
        if not isinstance(est, cls):
            raise StateFileError(f"{path}: holds the state of a {type(est).__name__}, "
                                 f"not a {cls.__name__}")
        return est

    def to_c(self, directory, *, name="fir", dtype="float64", nk=0, pending=None):
        r"""Write ``NAME.h`` and ``NAME.c``: this filter in C99, from its current state.

        ``NAME_update(s, u, y)`` takes the new raw input sample and returns the
        a-priori error; both methods (the lattice's ``NAME_theta`` solves
        :math:`R\theta = z` on request, with ``track_theta=True``); see
        :func:`adaptid.codegen.to_c`.

        Parameters
        ----------
        directory : str or os.PathLike
        name : str
            C identifier: file names and the prefix of every symbol.
        dtype : {"float64", "float32"}
        nk : int
            Input delay: the line holds :math:`v_k = u_{k-n_k}` and the C code
            keeps the nk raw inputs not yet in it.
        pending : array_like, shape (nk,), optional
            Those inputs at export, oldest first (zeros by default).

        Returns
        -------
        tuple of pathlib.Path
            The header and the source file.
        """
        from ._hooks import upward
        return upward("adaptid.codegen").to_c(self, directory, name=name, dtype=dtype, nk=nk,
                                              pending=pending)

    def __getstate__(self):
        return self.get_state()

    def __setstate__(self, state):
        self.__dict__.update(type(self).from_state(state).__dict__)


def _overflow_error():
    return param_error("u and y", "data whose squares stay within the float range (the "
                       "filter's energies are sums of squares; scale the data)",
                       "<energies that overflowed to inf>")


def _warn_overflow(E, skipped):
    """A non-finite a-priori error of a sample that was used: the data overflowed."""
    bad = ~np.isfinite(E) & ~skipped
    if bad.any():
        import warnings

        from .._exceptions import DivergenceWarning

        k = int(np.argmax(bad.reshape(-1)))
        warnings.warn(f"FastRLS: the a-priori error overflowed at sample {k} (flat index): "
                      "data beyond about 1e150 make the filter's energies (sums of "
                      "squares) infinite; scale the data", DivergenceWarning, stacklevel=4)


def _check_line(Phi, good, line, name):
    """Refuse rows (those with ``good``) that are not a delay line continuing ``line``."""
    rows = Phi[good]
    if rows.shape[0] == 0:
        return
    n = Phi.shape[1]
    seq = np.concatenate([line[: n - 1][::-1], rows[:, 0]])
    want = np.lib.stride_tricks.sliding_window_view(seq, n)[:, ::-1]
    bad = np.flatnonzero(np.any(rows != want, axis=1))
    if bad.size:
        k = int(np.flatnonzero(good)[bad[0]])
        raise param_error(name, "a tapped delay line: row k = [u_k, u_(k-1), ...], each row "
                          "the previous one (or the estimator's delay line) shifted by one "
                          "sample", f"<row {k} is not>")
