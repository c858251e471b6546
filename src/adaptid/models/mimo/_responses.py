r"""Responses of the MIMO ARX model with their uncertainty (first-order propagation).

The transfer matrix is :math:`G(q) = A(q)^{-1}B(q)`. A parameter enters
either B (:math:`b^{(ij)}_l`, at :math:`q^{-(n_k[i,j]+l)}` in entry (i, j))
or A (:math:`a^{(ij)}_l`, at :math:`q^{-l}` in entry (i, j)), so with
:math:`E_{ij}` the unit matrix

.. math::

    \frac{\partial G}{\partial b^{(ij)}_l} = A^{-1}E_{ij}\,q^{-(n_k+l)},\qquad
    \frac{\partial G}{\partial a^{(ij)}_l} = -A^{-1}E_{ij}\,q^{-l}\,G ,

evaluated at :math:`q^{-1} = e^{-i\omega\,dt}` for the frequency response,
and as the sensitivity filters :math:`A\,\partial s = E_{ij}q^{-k}u` and
:math:`A\,\partial s = -E_{ij}q^{-l}s` for the step response. With J the
Jacobian and Σ the covariance of the stacked θ (``cov``, which couples the
equations when A does), the variance of each entry is :math:`J\Sigma J^T`
(MATLAB's convention for |G| and arg G, as
:func:`adaptid.models.frequency._response.polar_sd`); exact for B-only
(FIR) models, whose response is linear in θ.
"""

from __future__ import annotations

import numpy as np

from ..._validation import as_float_array, check_int, param_error

__all__ = ["Responses"]


class Responses:
    """freqresp / step_response / poles / rsample of :class:`MIMOARX` (a mixin)."""

    def _params(self):
        """[(global index, equation i, kind, j, l)] for every parameter."""
        out = []
        for i, cols in enumerate(self._layout):
            start = self._slices[i].start
            out += [(start + c, i, kind, j, l) for c, (kind, j, l, _) in enumerate(cols)]
        return out

    def freqresp(self, w=None):
        r"""Frequency response :math:`G(e^{i\omega dt}) = A^{-1}B` with standard deviations.

        Parameters
        ----------
        w : array_like, optional
            Frequencies in rad per time unit of ``dt`` (default MATLAB's 128
            points :math:`\frac{k}{128}\frac{\pi}{dt}`).

        Returns
        -------
        FrequencyResponse
            ``response``, ``magnitude_sd``, ``phase_sd`` of shape (ny, nu, nw).
        """
        from ..frequency._response import FrequencyResponse, default_grid, polar_sd

        self._check_fitted()
        w = default_grid(self.dt) if w is None else as_float_array(w, "w", ndim=1)
        zinv = np.exp(-1j * w * self.dt)
        A, B = self._polymats()
        powers = zinv[:, None] ** np.arange(max(A.shape[0], B.shape[0]))[None, :]
        Aw = np.einsum("wl,lij->wij", powers[:, : A.shape[0]], A)
        Bw = np.einsum("wl,lij->wij", powers[:, : B.shape[0]], B)
        Ainv = np.linalg.solve(Aw, np.broadcast_to(np.eye(A.shape[1]), Aw.shape))
        G = Ainv @ Bw                                           # (nw, ny, nu)
        J = np.zeros(G.shape + (self.theta.size,), dtype=complex)
        nk = self._orders.nk
        for p, i, kind, j, l in self._params():
            if kind == "b":
                J[:, :, j, p] = powers[:, nk[i, j] + l, None] * Ainv[:, :, i]
            else:
                J[:, :, :, p] = -(zinv ** l)[:, None, None] * Ainv[:, :, i, None] * G[:, None, j, :]
        S = np.asarray(self.cov, dtype=float)
        Jr, Ji = J.real, J.imag
        c_rr = np.einsum("woup,pq,wouq->wou", Jr, S, Jr)
        c_ri = np.einsum("woup,pq,wouq->wou", Jr, S, Ji)
        c_ii = np.einsum("woup,pq,wouq->wou", Ji, S, Ji)
        ms, ps = polar_sd(G, c_rr, c_ri, c_ii)
        move = lambda X: np.moveaxis(X, 0, -1)  # noqa: E731
        return FrequencyResponse(w, move(G), self.dt, magnitude_sd=move(ms), phase_sd=move(ps),
                                 y_names=self.y_names, u_names=self.u_names)

    def _default_T(self):
        from ..frequency._step import default_length

        p = self.poles().values
        p = p[np.abs(p) > 0]
        return default_length(np.zeros(self.B.shape[0]), np.poly(p) if p.size else np.ones(1))

    def step_response(self, T=None):
        r"""Step responses (a unit step on each input at t = 0) with standard deviations.

        Parameters
        ----------
        T : int, optional
            Number of samples (default: 10 slowest time constants of the
            poles plus the length of B, within [20, 2000], as the SISO models).

        Returns
        -------
        StepResponse
            ``response`` and ``sd`` of shape (ny, nu, T).
        """
        from ..frequency._step import StepResponse, check_length

        self._check_fitted()
        T = self._default_T() if T is None else check_length(T)
        A, B = self._polymats()
        ny, nu = self._orders.ny, self._orders.nu
        S = np.zeros((T, ny, nu))
        for j in range(nu):
            U = np.zeros((T, nu))
            U[:, j] = 1.0
            S[:, :, j] = self._run(A, self._forcing(B, U))
        J = np.zeros((T, ny, nu, self.theta.size))
        nk = self._orders.nk
        for p, i, kind, j, l in self._params():
            for m in range(nu) if kind == "a" else (j,):
                F = np.zeros((T, ny))
                if kind == "b":
                    F[nk[i, j] + l:, i] = 1.0
                else:
                    F[l:, i] = -S[: T - l, j, m]
                J[:, :, m, p] = self._run(A, F)
        var = np.einsum("toup,pq,touq->tou", J, np.asarray(self.cov, dtype=float), J)
        move = lambda X: np.moveaxis(X, 0, -1)  # noqa: E731
        return StepResponse(np.arange(T) * self.dt, move(S), move(np.sqrt(np.maximum(var, 0.0))),
                            dt=self.dt, y_names=self.y_names, u_names=self.u_names)

    def poles(self):
        r"""Poles (roots of :math:`\det z^{L}A(z^{-1})`) with first-order standard deviations.

        The eigenvalues λ of the block companion matrix M of A (first block
        row :math:`[-A_1, \dots, -A_L]`); for a simple eigenvalue with left
        and right eigenvectors w, v,
        :math:`\partial\lambda/\partial M_{rc} = \bar w_rv_c/(w^Hv)`, and
        the covariance of θ gives the standard deviations of Re λ and Im λ
        (multiple eigenvalues: infinite or NaN).

        Returns
        -------
        Roots
        """
        from scipy import linalg

        from ..frequency._roots import Roots

        self._check_fitted()
        A = self._polymats()[0]
        ny, L = A.shape[1], A.shape[0] - 1
        if L == 0:
            return Roots(np.zeros(0, dtype=complex), np.zeros(0), np.zeros(0))
        M = np.zeros((ny * L, ny * L))
        M[:ny] = -np.hstack(list(A[1:]))
        M[ny:, : ny * (L - 1)] = np.eye(ny * (L - 1))
        lam, vl, vr = linalg.eig(M, left=True, right=True)
        g = np.zeros((lam.size, self.theta.size), dtype=complex)
        with np.errstate(divide="ignore", invalid="ignore"):
            scale = np.einsum("rk,rk->k", vl.conj(), vr)
            for p, i, kind, j, l in self._params():
                if kind == "a":
                    g[:, p] = -vl[i].conj() * vr[(l - 1) * ny + j] / scale
        S = np.asarray(self.cov, dtype=float)
        with np.errstate(invalid="ignore"):
            vr_ = np.einsum("ri,ij,rj->r", g.real, S, g.real)
            vi_ = np.einsum("ri,ij,rj->r", g.imag, S, g.imag)
        return Roots(lam, np.sqrt(np.abs(vr_)), np.sqrt(np.abs(vi_)))

    def _observer_form(self, theta=None):
        """(A, B, C, D) of the block observer-canonical realization of A(q)⁻¹B(q)."""
        A, B = self._polymats(theta)
        ny, nu = A.shape[1], B.shape[2]
        L = max(A.shape[0] - 1, B.shape[0] - 1, 1)
        Ap = np.zeros((L + 1, ny, ny))
        Ap[:A.shape[0]] = A
        Bp = np.zeros((L + 1, ny, nu))
        Bp[:B.shape[0]] = B
        D = Bp[0]
        Ao, Bo = np.zeros((ny * L, ny * L)), np.zeros((ny * L, nu))
        for i in range(1, L + 1):
            rows = slice((i - 1) * ny, i * ny)
            Ao[rows, :ny] = -Ap[i]
            if i < L:
                Ao[rows, i * ny:(i + 1) * ny] = np.eye(ny)
            Bo[rows] = Bp[i] - Ap[i] @ D
        C = np.zeros((ny, ny * L))
        C[:, :ny] = np.eye(ny)
        return Ao, Bo, C, D.copy()

    def zeros(self):
        r"""Transmission zeros with first-order standard deviations.

        The invariant zeros of the block observer-canonical realization of
        :math:`A(q)^{-1}B(q)` (:math:`x_1 = y - B_0u`, :math:`x_{i+1}` the
        remaining lags; observable, and controllable when A and B are left
        coprime): the finite generalised eigenvalues of the Rosenbrock pencil
        (Emami-Naeini and Van Dooren 1982), as
        :meth:`adaptid.models.StateSpaceModel.zeros` computes them. The
        parameter covariance is carried to the realization's entries by
        their Jacobian in θ (exact central differences: each entry is at
        most linear in any one coefficient), then to each simple zero by
        :math:`\partial z = w^H(\partial F)v/(w^HEv)`.

        Returns
        -------
        Roots or list of lists of Roots
            One ``Roots`` for a square model (ny = nu), else ``[output][input]``
            the zeros of each channel.
        """
        from ..statespace._uncertainty import pack, zeros_sd

        self._check_fitted()
        Ao, Bo, C, D = self._observer_form()
        K = np.zeros((Ao.shape[0], C.shape[0]))
        d = self.theta.size
        J = np.empty((pack(Ao, Bo, C, D, K).size, d))
        for j in range(d):
            e = np.zeros(d)
            e[j] = 1.0
            hi = pack(*self._observer_form(self.theta + e), K)
            lo = pack(*self._observer_form(self.theta - e), K)
            J[:, j] = 0.5 * (hi - lo)
        cov = J @ np.asarray(self.cov, dtype=float) @ J.T
        out = zeros_sd(_Realization(Ao, Bo, C, D), cov)
        if isinstance(out, list):
            return [[_transmission(r, Ao, Bo[:, [c]], C[[i]]) for c, r in enumerate(row)]
                    for i, row in enumerate(out)]
        return _transmission(out, Ao, Bo, C)

    def rsample(self, n, seed=None):
        r"""n models with θ drawn from :math:`N(\hat\theta, \mathrm{cov})`: MATLAB's ``rsample``.

        Parameters
        ----------
        n : int
            Number of models, ``>= 1``.
        seed : int or numpy.random.Generator, optional

        Returns
        -------
        list of MIMOARX
            Shallow copies with ``theta`` replaced (the other statistics are this fit's).
        """
        import copy

        self._check_fitted()
        n = check_int(n, "n", low=1)
        if self.cov is None or not np.all(np.isfinite(self.cov)):
            raise param_error("self", "a model with a finite parameter covariance", "<cov>")
        rng = np.random.default_rng(seed)
        thetas = rng.multivariate_normal(self.theta, np.asarray(self.cov, dtype=float), size=n,
                                         method="eigh")
        out = []
        for th in thetas:
            m = copy.copy(self)
            m.theta = th
            out.append(m)
        return out


class _Realization:
    """A, B, C, D of a realization (what :func:`..statespace._uncertainty.zeros_sd` reads)."""

    def __init__(self, A, B, C, D):
        self.A, self.B, self.C, self.D = A, B, C, D


def _transmission(roots, A, B, C, rtol=1e-7):
    """``roots`` without the decoupling zeros of (A, B, C) (PBH rank test at each zero)."""
    from ..frequency._roots import Roots

    n = A.shape[0]
    scale = max(np.abs(A).max(), np.abs(B).max(), np.abs(C).max(), 1.0)
    keep = []
    for z in roots.values:
        M = A - z * np.eye(n)
        sc = np.linalg.svd(np.hstack([M, B]), compute_uv=False)[-1] if n else 1.0
        so = np.linalg.svd(np.vstack([M, C]), compute_uv=False)[-1] if n else 1.0
        keep.append(min(sc, so) > rtol * scale)
    keep = np.array(keep, dtype=bool)
    pick = (lambda a: None if a is None else np.asarray(a)[keep])  # noqa: E731
    return Roots(roots.values[keep], pick(roots.sd_real), pick(roots.sd_imag))

