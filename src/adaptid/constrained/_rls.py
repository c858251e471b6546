r"""Recursive least squares under linear equality constraints."""

from __future__ import annotations

import numpy as np
import scipy.linalg as sla

from .._validation import as_float_array, check_int, check_spd, param_error
from ._linalg import numerical_rank

__all__ = ["ConstrainedRLS"]

_STATE_FORMAT = 1


class ConstrainedRLS:
    r"""Recursive least squares subject to :math:`C\theta = d` at every step.

    After samples 1..N, :attr:`theta` is the exact minimiser of the cost of
    :class:`adaptid.RLS` restricted to the affine set :math:`C\theta = d`:

    .. math::

        \min_{C\theta = d}\;
        \sum_{k=1}^{N} \Big(\prod_{i=k+1}^{N}\lambda_i\Big) w_k
            (y_k - \varphi_k^T\theta)^2
          + \Big(\prod_{i=1}^{N}\lambda_i\Big)(\theta-\theta_0)^T P_0^{-1}(\theta-\theta_0).

    Parameters
    ----------
    n_params : int
        Number of parameters n.
    C : array_like, shape (p, n)
        Constraint matrix, full row rank, p < n.
    d : array_like, shape (p,)
        Constraint right-hand side.
    forgetting : float
        λ ∈ (0, 1] (default 1); per-sample values go to :meth:`update` /
        :meth:`run`, as for :class:`adaptid.RLS`.
    theta0 : array_like, shape (n,), optional
        Prior mean (default zeros); it need not satisfy the constraints.
    P0 : float or array_like, shape (n, n)
        Prior covariance (scalar c means c·I, default 1e4), SPD.
    nan_policy : {"raise", "skip"}
        As for :class:`adaptid.RLS`.

    Attributes
    ----------
    theta : ndarray, shape (n,) — or (B, n) after :meth:`run_batched`
        Current estimate; satisfies ``C theta = d`` to rounding.
    P : ndarray, shape (n, n) — or (B, n, n)
        ``N P_z Nᵀ``: the inverse of half the Hessian of the cost on the
        affine set, embedded in ℝⁿ (rank n − p, ``C P = 0``).
    n_updates, n_skipped : int

    Notes
    -----
    Null-space parametrisation :math:`\theta = \theta_p + N z`, with ``N``
    an orthonormal basis of null(C) and :math:`\theta_p` the minimum-norm
    solution of :math:`C\theta = d` (both from one QR factorisation of
    :math:`C^T`). The cost becomes an unconstrained RLS cost in ``z`` with
    regressor :math:`N^T\varphi` and target :math:`y - \varphi^T\theta_p`;
    the prior restricted to the affine set is exactly a Gaussian prior on
    ``z`` (up to a constant),

    .. math::

        P_{z,0} = (N^T P_0^{-1} N)^{-1}, \qquad
        z_0 = P_{z,0} N^T P_0^{-1} (\theta_0 - \theta_p),

    computed from the Cholesky factor of :math:`P_0` and a QR
    factorisation, without an explicit inverse of :math:`P_0`. The core
    :class:`adaptid.RLS` (U-D factored, compiled) runs on ``z``. The a-priori
    error is the same in both parametrisations. Source: Boyd &
    Vandenberghe (2018), §16.1 (constrained least squares) with the
    recursive update of Ljung & Söderström (1983), eqs. 2.19–2.20.

    Examples
    --------
    >>> import numpy as np
    >>> from adaptid.constrained import ConstrainedRLS
    >>> est = ConstrainedRLS(3, C=[[1.0, 1.0, 1.0]], d=[1.0])
    >>> err = est.update([1.0, 2.0, 0.0], 0.5)
    >>> bool(np.isclose(est.theta.sum(), 1.0))
    True
    """

    #: state-dict keys stored as arrays of a state file, and their names there
    _STATE_FILE_ARRAYS = {"C": "C", "d": "d", "theta0": "outer_theta0", "P0": "outer_P0"}

    def __init__(self, n_params, C, d, *, forgetting=1.0, theta0=None, P0=1e4,
                 nan_policy="raise"):
        from ..estimators import RLS  # numba-compiled core, loaded on first use

        n = check_int(n_params, "n_params", low=1)
        C = as_float_array(C, "C", ndim=2, copy=True)
        if C.shape[1] != n:
            raise param_error("C", f"of shape (p, {n}) for n_params={n}", f"<shape {C.shape}>")
        p = C.shape[0]
        if p >= n:
            raise param_error("C", f"of fewer rows than n_params={n} (some parameter "
                              "left free)", f"<shape {C.shape}>")
        d = as_float_array(d, "d", shape=(p,), copy=True)
        if theta0 is None:
            th0 = np.zeros(n)
        else:
            th0 = as_float_array(theta0, "theta0", shape=(n,), copy=True)
        P0m = check_spd(P0, "P0", n)

        if p:
            Q, R, piv = sla.qr(C.T, pivoting=True)          # Cᵀ Π = Q R (complete Q)
            rank = numerical_rank(R[:p], C.T.shape)
            if rank < p:
                raise param_error("C", "of full row rank (linearly independent constraints)",
                                  f"<rank {rank} < {p} rows>")
            Q1, N = Q[:, :p], Q[:, p:]
            # C θ = d  ⇔  Rᵀ Q₁ᵀ θ = Πᵀ d; minimum-norm solution θ_p = Q₁ w
            theta_p = Q1 @ sla.solve_triangular(R[:p], d[piv], trans="T")
        else:
            N, theta_p = np.eye(n), np.zeros(n)
        # Prior on z: with P0 = L Lᵀ and W = L⁻¹N = Q_w R_w,
        # NᵀP0⁻¹N = R_wᵀR_w, z0 = R_w⁻¹ Q_wᵀ L⁻¹(θ0 − θ_p).
        L = np.linalg.cholesky(P0m)
        W = sla.solve_triangular(L, N, lower=True)
        Qw, Rw = sla.qr(W, mode="economic")
        z0 = sla.solve_triangular(
            Rw, Qw.T @ sla.solve_triangular(L, th0 - theta_p, lower=True))
        Rinv = sla.solve_triangular(Rw, np.eye(n - p))
        Pz0 = Rinv @ Rinv.T
        Pz0 = 0.5 * (Pz0 + Pz0.T)

        self.n_params = n
        self.C, self.d = C, d
        self.theta0, self.P0 = th0, P0m
        self.null_basis = N
        self.theta_particular = theta_p
        self._rls = RLS(n - p, forgetting=forgetting, theta0=z0, P0=Pz0,
                        nan_policy=nan_policy)

    # ------------------------------------------------------------ properties
    @property
    def forgetting(self) -> float:
        return self._rls.forgetting

    @property
    def nan_policy(self) -> str:
        return self._rls.nan_policy

    @property
    def n_updates(self) -> int:
        return self._rls.n_updates

    @property
    def n_skipped(self) -> int:
        return self._rls.n_skipped

    @property
    def batch_size(self):
        return self._rls.batch_size

    @property
    def theta(self) -> np.ndarray:
        """Current estimate θ = θ_p + N z, shape (n,) or (B, n)."""
        return self._from_z(self._rls.theta)

    @property
    def P(self) -> np.ndarray:
        """``N P_z Nᵀ``, shape (n, n) or (B, n, n)."""
        N = self.null_basis
        return N @ self._rls.P @ N.T

    # ------------------------------------------------------------ transforms
    def _phi(self, phi, name="phi", ndim=1):
        phi = as_float_array(phi, name, ndim=ndim, finite=False)
        if phi.shape[-1] != self.n_params:
            raise param_error(name, f"with last axis n_params={self.n_params}",
                              f"<shape {phi.shape}>")
        return phi

    def _transform(self, Phi, Y):
        """Regressors Φ N and targets y − Φ θ_p for the RLS on z.

        Summed column by column with element-wise NumPy operations, so that
        each sample's result does not depend on how many samples are
        transformed together: :meth:`run` then equals repeated
        :meth:`update` bit for bit (a BLAS product may round differently).
        """
        N, tp = self.null_basis, self.theta_particular
        Phi_z = np.zeros(Phi.shape[:-1] + (N.shape[1],))
        Y_z = Y.copy()
        with np.errstate(invalid="ignore", over="ignore"):  # non-finite: nan_policy
            for i in range(self.n_params):
                col = Phi[..., i, None]
                Phi_z += col * N[i]
                Y_z -= col[..., 0] * tp[i]
        return Phi_z, Y_z

    def _from_z(self, Z):
        """θ = θ_p + N z, element-wise like :meth:`_transform` (same rounding everywhere)."""
        N = self.null_basis
        out = np.broadcast_to(self.theta_particular, Z.shape[:-1] + (self.n_params,)).copy()
        for j in range(N.shape[1]):
            out += Z[..., j, None] * N[:, j]
        return out

    def _to_theta(self, traj):
        from ..estimators import Trajectory
        th = self._from_z(traj.theta)
        return Trajectory(theta=th, error=traj.error, skipped=traj.skipped,
                          n_rebuilds=traj.n_rebuilds)

    # --------------------------------------------------------------- updates
    def update(self, phi, y, *, weight=1.0, forgetting=None) -> float:
        r"""Process one sample; returns the a-priori error ε = y − φᵀθ.

        Parameters
        ----------
        phi : array_like, shape (n,)
        y : float
        weight : float
            wₖ ≥ 0.
        forgetting : float, optional
            λₖ ∈ (0, 1] for this step.

        Returns
        -------
        float
        """
        phi = self._phi(phi)
        yv = as_float_array(y, "y", ndim=(0, 1), finite=False)
        if yv.size != 1:
            raise param_error("y", "a scalar", f"<shape {yv.shape}>")
        phi_z, y_z = self._transform(phi, yv.reshape(()))
        return self._rls.update(phi_z, float(y_z), weight=weight, forgetting=forgetting)

    def run(self, Phi, y, *, weights=None, forgetting=None, store=True):
        r"""Process N samples in one compiled loop (the core RLS's).

        Parameters
        ----------
        Phi : array_like, shape (N, n)
        y : array_like, shape (N,)
        weights, forgetting : float or array_like, shape (N,), optional

        Returns
        -------
        Trajectory
            ``.theta`` (N, n) — each row satisfies the constraints — and
            ``.error`` (N,), the a-priori errors. Equal to N calls of
            :meth:`update` bit for bit.
        """
        Phi = self._phi(Phi, "Phi", ndim=2)
        Y = as_float_array(y, "y", shape=(Phi.shape[0],), finite=False)
        Phi_z, Y_z = self._transform(Phi, Y)
        traj = self._rls.run(Phi_z, Y_z, weights=weights, forgetting=forgetting, store=store)
        return self._to_theta(traj)

    def run_batched(self, Phi, y, *, weights=None, forgetting=None, store=True):
        r"""B independent streams in one compiled call.

        Parameters
        ----------
        Phi : array_like, shape (B, N, n)
        y : array_like, shape (B, N)

        Returns
        -------
        Trajectory
            ``.theta`` (B, N, n), ``.error`` (B, N); afterwards ``theta`` and
            ``P`` carry the leading axis B.
        """
        Phi = self._phi(Phi, "Phi", ndim=3)
        Y = as_float_array(y, "y", shape=Phi.shape[:2], finite=False)
        Phi_z, Y_z = self._transform(Phi, Y)
        traj = self._rls.run_batched(Phi_z, Y_z, weights=weights, forgetting=forgetting,
                                     store=store)
        return self._to_theta(traj)

    def predict(self, phi):
        r"""Predicted output :math:`\varphi^T\hat\theta`; phi of shape (n,) or (N, n)."""
        if self._rls.batch_size is not None:
            phi = self._phi(phi, ndim=(2, 3))
            return np.einsum("b...i,bi->b...", phi, self.theta)
        phi = self._phi(phi, ndim=(1, 2))
        out = phi @ self.theta
        return float(out) if out.ndim == 0 else out

    def reset(self):
        """Return to the prior and forget all data."""
        self._rls.reset()
        return self

    def copy(self):
        """An independent copy."""
        return type(self).from_state(self.get_state())

    # ----------------------------------------------------------- state dicts
    def get_state(self) -> dict:
        """Everything needed to resume exactly (plain values and float64 arrays)."""
        return {
            "estimator": "ConstrainedRLS",
            "format": _STATE_FORMAT,
            "n_params": self.n_params,
            "C": self.C.copy(),
            "d": self.d.copy(),
            "theta0": self.theta0.copy(),
            "P0": self.P0.copy(),
            "options": {"forgetting": self.forgetting, "nan_policy": self.nan_policy},
            "inner": self._rls.get_state(),
        }

    @classmethod
    def from_state(cls, state: dict) -> "ConstrainedRLS":
        """Rebuild from :meth:`get_state`'s dict (exact round trip)."""
        from ..estimators import RLS
        if not isinstance(state, dict):
            raise param_error("state", "a dict from get_state()", state, exc=TypeError)
        if state.get("estimator") != "ConstrainedRLS":
            raise param_error("state", "the state of a ConstrainedRLS",
                              f"<estimator {state.get('estimator')!r}>")
        if state.get("format") != _STATE_FORMAT:
            raise param_error("state['format']", f"{_STATE_FORMAT}", state.get("format"))
        try:
            opts = dict(state["options"])
            est = cls(state["n_params"], state["C"], state["d"], theta0=state["theta0"],
                      P0=state["P0"], **opts)
            inner = RLS.from_state(state["inner"])
        except KeyError as err:
            raise param_error("state", "a complete dict from get_state()",
                              f"<missing key {err.args[0]!r}>") from None
        if inner.n_params != est._rls.n_params:
            raise param_error("state['inner']", f"an RLS of {est._rls.n_params} parameters",
                              f"<{inner.n_params} parameters>")
        est._rls = inner
        return est

    def save_state(self, path):
        """Write the state to ``path`` (versioned, checksummed ``.npz``; never pickle).

        The same safe format as :meth:`adaptid.RLS.save_state`: the inner
        estimator on the reduced parameters plus C, d and the prior. Written
        to a temporary name and renamed, so a crash never leaves half a file.
        """
        from ..estimators import save_state
        save_state(self, path)

    @classmethod
    def load_state(cls, path) -> "ConstrainedRLS":
        """Read a file written by :meth:`save_state`; raises StateFileError if it is damaged."""
        from .._exceptions import StateFileError
        from ..estimators import load_state
        est = load_state(path)
        if not isinstance(est, cls):
            raise StateFileError(f"{path}: holds the state of a {type(est).__name__}, "
                                 f"not a {cls.__name__}")
        return est

    def __repr__(self) -> str:
        return (f"ConstrainedRLS(n_params={self.n_params}, n_constraints={self.C.shape[0]}, "
                f"forgetting={self.forgetting!r}, n_updates={self.n_updates})")
