r"""Roots of polynomials with their standard deviations (first-order).

For a polynomial :math:`p(z) = \sum_{j=0}^n c_j z^{n-j}` with a simple root
r, the implicit-function theorem gives

.. math::

    \frac{\partial r}{\partial c_j} = -\frac{\partial p/\partial c_j}{p'(r)}
    = -\frac{r^{n-j}}{p'(r)} ,

so with the complex gradient g (one entry per parameter) and the parameter
covariance Σ, the variances of the real and imaginary parts are
:math:`(\operatorname{Re}g)^\top\Sigma\operatorname{Re}g` and
:math:`(\operatorname{Im}g)^\top\Sigma\operatorname{Im}g`. A multiple root
(:math:`p'(r) = 0`) has an infinite standard deviation: the first-order
approximation fails there.
"""

from __future__ import annotations

import numpy as np

__all__ = ["Roots", "roots_with_sd", "roots_from_gradients"]


class Roots:
    r"""Roots with the standard deviations of their real and imaginary parts.

    Attributes
    ----------
    values : ndarray of complex, shape (n,)
    sd_real, sd_imag : ndarray, shape (n,), or None
        First-order standard deviations of Re r and Im r (None without a
        covariance); for a real root ``sd_imag`` is 0.
    """

    def __init__(self, values, sd_real=None, sd_imag=None):
        self.values = np.asarray(values, dtype=complex)
        self.sd_real = sd_real
        self.sd_imag = sd_imag

    def __len__(self):
        return self.values.size

    def __iter__(self):
        """The roots in order (as iterating the ``values`` array): ``sorted(m.poles())`` works."""
        return iter(self.values)

    def __getitem__(self, key):
        """``roots[k]`` is the k-th root (a complex number); slices give arrays."""
        return self.values[key]

    @property
    def real(self):
        """Real parts of the roots (as ``ndarray.real``)."""
        return self.values.real

    @property
    def imag(self):
        """Imaginary parts of the roots (as ``ndarray.imag``)."""
        return self.values.imag

    @property
    def size(self):
        """Number of roots."""
        return self.values.size

    def __array__(self, dtype=None, copy=None):
        return self.values if dtype is None else self.values.astype(dtype)

    def to_frame(self):
        """Table with columns ``real``, ``imag``, ``abs``, ``sd_real``, ``sd_imag``."""
        import pandas as pd

        cols = {"real": self.values.real, "imag": self.values.imag, "abs": np.abs(self.values)}
        if self.sd_real is not None:
            cols["sd_real"], cols["sd_imag"] = self.sd_real, self.sd_imag
        return pd.DataFrame(cols)

    def __repr__(self):
        parts = []
        for k, r in enumerate(self.values):
            s = f"{r:.4g}"
            if self.sd_real is not None:
                s += f" (sd {self.sd_real[k]:.2g}, {self.sd_imag[k]:.2g}j)"
            parts.append(s)
        return "Roots([" + ", ".join(parts) + "])"


def roots_with_sd(factors, cov=None, d=None):
    """Roots of polynomials in q⁻¹ with their first-order standard deviations.

    Parameters
    ----------
    factors : list of (coefficients in q⁻¹, [(θ index, power of q⁻¹), …])
        Each factor's roots in z (of :math:`z^n p(z^{-1})`, leading zero
        coefficients — pure delays — removed); the roots of all factors
        are concatenated.
    cov : ndarray (d, d), optional
    d : int
        Number of parameters (required with ``cov``).

    Returns
    -------
    Roots
    """
    vals, grads = [], []
    for p, par in factors:
        p = np.asarray(p, dtype=float)
        nz = np.flatnonzero(p)
        if nz.size == 0:
            continue
        off = int(nz[0])
        c = p[off:]                           # c[j] multiplies z^{n-j}
        n = c.size - 1
        if n == 0:
            continue
        r = np.roots(c)
        dp = np.polyval(np.polyder(c), r)
        vals.append(r)
        if cov is not None:
            g = np.zeros((r.size, d), dtype=complex)
            with np.errstate(divide="ignore", invalid="ignore"):
                for j, k in par:
                    jj = k - off
                    if 0 <= jj <= n:
                        g[:, j] += -(r ** (n - jj)) / dp
            grads.append(g)
    values = np.concatenate(vals) if vals else np.zeros(0, dtype=complex)
    if cov is None:
        return Roots(values)
    G = np.concatenate(grads) if grads else np.zeros((0, d), dtype=complex)
    return roots_from_gradients(values, G, cov)


def roots_from_gradients(values, G, cov):
    r"""Roots with standard deviations from their complex gradients G (r, d) and Σ (d, d).

    :math:`\operatorname{var}\operatorname{Re}r =
    (\operatorname{Re}g)^\top\Sigma\operatorname{Re}g`,
    likewise for the imaginary part.
    """
    S = np.asarray(cov, dtype=float)
    with np.errstate(invalid="ignore"):
        vr = np.einsum("ri,ij,rj->r", G.real, S, G.real)
        vi = np.einsum("ri,ij,rj->r", G.imag, S, G.imag)
    return Roots(values, np.sqrt(np.abs(vr)), np.sqrt(np.abs(vi)))
