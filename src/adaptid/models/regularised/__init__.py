r"""Regularised (kernel-based) estimation: impulse responses and ARX.

* :func:`impulseest` — FIR model by regularised least squares with a TC, DC,
  SS, SE, HF or DI kernel (MATLAB's ``impulseest``);
* :func:`arx_regul` — regularised ARX (MATLAB's ``arxRegul`` followed by
  ``arx`` with the regularisation), one kernel for A and one for each B;
* :func:`kernel_matrix` — the prior covariance P of a kernel.

Hyperparameters maximise the marginal likelihood (empirical Bayes).
"""

from ._kernel import arx_regul, impulseest, kernel_matrix

__all__ = ["impulseest", "arx_regul", "kernel_matrix"]
