"""The frequency-domain methods of the polynomial models, with their uncertainty.

``freqresp``, ``step_response``, ``poles``, ``zeros`` and ``rsample`` of
:class:`~adaptid.models._polymodel._PolyModel` (ARX, ARMAX, OE, BJ; AR and
ARMA through their noise model), written once for every structure: the model
supplies θ, its covariance and the polynomials of :meth:`_freq_structure`;
the arithmetic (delta method, analytic Jacobians) is in
:mod:`adaptid.models.frequency`.
"""

from __future__ import annotations

import numpy as np

from .._validation import as_float_array, check_int, param_error

__all__ = ["FrequencyMethods"]


class FrequencyMethods:
    """Mixin of :class:`~adaptid.models._polymodel._PolyModel`: responses with bands."""

    def _freq_structure(self):
        """The transfer functions as rational functions of θ, one per input.

        A list of ``(num, dens)``: ``num`` and every entry of ``dens`` are
        ``(coefficients in q⁻¹, [(θ index, power of q⁻¹), …])`` — which
        parameter multiplies which power (read off :meth:`_split` applied to
        the indices themselves, so every model's θ order is respected).
        Here :math:`G_i = B_i / (A F_i)`.
        """
        d = self.theta.size
        a_i, bs_i, _, fs_i = self._split(np.arange(d, dtype=float))
        A, Bs, _, Fs = self._polys()
        A_par = [(int(j), k + 1) for k, j in enumerate(a_i)]
        out = []
        for i in range(self._m):
            B_par = [(int(j), self._nk[i] + k) for k, j in enumerate(bs_i[i])]
            F_par = [(int(j), k + 1) for k, j in enumerate(fs_i[i])]
            out.append(((Bs[i], B_par), [(A, A_par), (Fs[i], F_par)]))
        return out

    def _freq_names(self):
        return (getattr(self, "y_name", "y"),), tuple(getattr(self, "u_names", ())) or None

    def freqresp(self, w=None):
        r"""Frequency response with standard deviations from the parameter covariance.

        :math:`G_i(e^{i\omega dt}) = B_i/(A F_i)` evaluated at
        :math:`q^{-1} = e^{-i\omega\,dt}` (for :class:`AR`/:class:`ARMA`
        the noise model :math:`H = C/A`, as their ``to_control``). The
        derivative of the rational function with respect to each parameter
        is analytic: for a numerator coefficient at :math:`q^{-k}`,
        :math:`\partial G/\partial\theta = e^{-i\omega k\,dt}/D`; for a
        coefficient at :math:`q^{-k}` of a denominator factor P,
        :math:`\partial G/\partial\theta = -G\,e^{-i\omega k\,dt}/P`. With J
        the 2 × d Jacobian of (Re G, Im G) and Σ the parameter covariance
        (``cov``), the covariance of (Re G, Im G) is :math:`J\Sigma J^\top`
        (first order), mapped to the standard deviations of :math:`|G|` and
        :math:`\arg G` by the delta method (MATLAB's convention: with
        :math:`G = x + iy`,
        :math:`\sigma_{|G|}^2 = (x^2c_{rr} + 2xy\,c_{ri} + y^2c_{ii})/|G|^2` and
        :math:`\sigma_{\arg G}^2 = (y^2c_{rr} - 2xy\,c_{ri} + x^2c_{ii})/|G|^4`).

        Parameters
        ----------
        w : array_like, optional
            Frequencies in rad per time unit of ``dt`` (default MATLAB's
            128 points :math:`\frac{k}{128}\frac{\pi}{dt}`, k = 1 … 128).

        Returns
        -------
        FrequencyResponse
            ``response`` of shape (nw,) for one input, (1, m, nw) for m
            inputs; no standard deviations when the model has no ``cov``.
        """
        from .frequency._response import FrequencyResponse, default_grid, polar_sd

        self._check_fitted()
        w = default_grid(self.dt) if w is None else as_float_array(w, "w", ndim=1)
        zinv = np.exp(-1j * w * self.dt)
        cov = getattr(self, "cov", None)
        d = self.theta.size
        Gs, msds, psds = [], [], []
        for (num, num_par), dens in self._freq_structure():
            val = lambda p: np.polyval(p[::-1], zinv)   # noqa: E731 - Σ p_k z^{-k}
            N_ = val(num)
            D_vals = [val(p) for p, _ in dens]
            D = np.prod(D_vals, axis=0) if D_vals else np.ones_like(zinv)
            G = N_ / D
            J = np.zeros((w.size, d), dtype=complex)
            for j, k in num_par:
                J[:, j] += zinv ** k / D
            for (_, par), P in zip(dens, D_vals):
                for j, k in par:
                    J[:, j] -= G * zinv ** k / P
            Gs.append(G)
            if cov is not None:
                S = np.asarray(cov, dtype=float)
                Jr, Ji = J.real, J.imag
                c_rr = np.einsum("wi,ij,wj->w", Jr, S, Jr)
                c_ri = np.einsum("wi,ij,wj->w", Jr, S, Ji)
                c_ii = np.einsum("wi,ij,wj->w", Ji, S, Ji)
                ms, ps = polar_sd(G, c_rr, c_ri, c_ii)
                msds.append(ms)
                psds.append(ps)
        y_names, u_names = self._freq_names()
        if len(Gs) == 1:
            shape = lambda xs: xs[0]   # noqa: E731
        else:
            shape = lambda xs: np.stack(xs)[None, :, :]   # noqa: E731
        return FrequencyResponse(w, shape(Gs), self.dt,
                                 magnitude_sd=shape(msds) if msds else None,
                                 phase_sd=shape(psds) if psds else None,
                                 y_names=y_names, u_names=u_names)

    def step_response(self, T=None):
        r"""Step response of :math:`G_i = B_i/(A F_i)` with its standard deviation per sample.

        The output after a unit step on each input at t = 0 (zero initial
        conditions), over T samples. The standard deviation is the
        first-order propagation of the parameter covariance with the analytic
        Jacobian of :func:`adaptid.models.frequency._step.step_with_sd`
        (a numerator coefficient at :math:`q^{-k}` contributes
        :math:`q^{-k}\mathbb 1/(AF_i)`, a denominator coefficient at
        :math:`q^{-k}` of a factor P contributes :math:`-q^{-k}s/P`); exact
        for FIR models (s linear in θ).

        Parameters
        ----------
        T : int, optional
            Number of samples. Default: ten times the slowest time constant
            :math:`-1/\ln\max|p|` (in samples, over all inputs' poles) plus
            the numerator length, within [20, 2000]; 2000 when a pole is on or
            outside the unit circle.

        Returns
        -------
        StepResponse
            ``t = k·dt``; ``response`` and ``sd`` of shape (T,) for one input,
            (1, m, T) for m inputs (``sd`` None without ``cov``).
        """
        from .frequency._step import StepResponse, check_length, default_length, step_with_sd

        self._check_fitted()
        structure = self._freq_structure()
        if T is None:
            T = 0
            for num, dens in structure:
                D = np.ones(1)
                for p, _ in dens:
                    D = np.convolve(D, p)
                T = max(T, default_length(num[0], D))
        else:
            T = check_length(T)
        cov = getattr(self, "cov", None)
        ss, sds = [], []
        for (num, num_par), dens in structure:
            s, sd = step_with_sd(num, num_par, dens, T, cov)
            ss.append(s)
            sds.append(sd)
        y_names, u_names = self._freq_names()
        u_names = u_names or tuple(f"u{i + 1}" for i in range(len(ss)))
        if len(ss) == 1:
            resp, sd = ss[0], sds[0]
        else:
            resp = np.stack(ss)[None]
            sd = None if cov is None else np.stack(sds)[None]
        return StepResponse(np.arange(T) * self.dt, resp, sd, dt=self.dt, y_names=y_names,
                            u_names=u_names if len(ss) > 1 else u_names[:1])

    def _roots(self, which):
        from .frequency._roots import roots_with_sd

        self._check_fitted()
        cov = getattr(self, "cov", None)
        out = []
        for num, dens in self._freq_structure():
            factors = [num] if which == "zeros" else dens
            out.append(roots_with_sd(factors, cov, self.theta.size))
        return out[0] if len(out) == 1 else out

    def poles(self):
        r"""Poles (in z) of :math:`G_i = B_i/(A F_i)` with first-order standard deviations.

        The roots of A and of :math:`F_i` (as polynomials in z:
        :math:`z^{n}A(z^{-1})`); for a simple root r of
        :math:`p(z) = \sum_j c_j z^{n-j}`,
        :math:`\partial r/\partial c_j = -r^{n-j}/p'(r)`, and the
        covariance gives the standard deviations of Re r and Im r
        (see :mod:`adaptid.models.frequency._roots`). Multiple roots get an
        infinite (or NaN) standard deviation.

        Returns
        -------
        Roots or list of Roots
            ``values``, ``sd_real``, ``sd_imag``; one per input when there
            are several inputs.
        """
        return self._roots("poles")

    def zeros(self):
        r"""Finite zeros (in z) of :math:`B_i` with first-order standard deviations.

        The roots of :math:`b_0 z^{n_b-1} + \dots + b_{n_b-1}` (the input
        delay :math:`q^{-n_k}` contributes no finite zero here); standard
        deviations as in :meth:`poles`.

        Returns
        -------
        Roots or list of Roots
        """
        return self._roots("zeros")

    def rsample(self, n, seed=None):
        r"""n models with parameters drawn from :math:`N(\hat\theta, \Sigma)`: MATLAB's ``rsample``.

        For Monte Carlo bands: each is a shallow copy of this model with
        ``theta`` replaced (its ``cov``, residuals and other statistics are
        those of this fit).

        Parameters
        ----------
        n : int
            Number of models, ``>= 1``.
        seed : int or numpy.random.Generator, optional

        Returns
        -------
        list
            n models of this model's type.
        """
        import copy

        self._check_fitted()
        n = check_int(n, "n", low=1)
        cov = getattr(self, "cov", None)
        if cov is None:
            raise param_error("self", "a model with a parameter covariance (cov)", "<cov None>")
        rng = np.random.default_rng(seed)
        thetas = rng.multivariate_normal(self.theta, np.asarray(cov, dtype=float), size=n,
                                         method="eigh")
        out = []
        for th in thetas:
            m = copy.copy(self)
            m.theta = th
            out.append(m)
        return out
