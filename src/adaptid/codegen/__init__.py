r"""Layer 7: C code generation for the recursive estimators (``to_c``).

An estimator identified in Python is exported as a dependency-free C99 file
pair that continues from its current state: the same U-D (Bierman)
recursion (or, for LMS / NLMS, the same gradient step), operation for
operation, for a microcontroller's control loop.
See ``docs/embedded.md``.
"""

from __future__ import annotations

from ._generate import generate, write

__all__ = ["to_c", "generate_c"]


def to_c(est, directory, *, name="rls", dtype="float64", offsets=None, nk=0, pending=None):
    r"""Write ``NAME.h`` and ``NAME.c``: the estimator's recursion in C, from its current state.

    ``est`` may also be a model: a fitted :class:`~adaptid.models.ARX` /
    :class:`~adaptid.models.AR` (θ fixed) or a streaming
    :class:`~adaptid.models.RecursiveARX` / :class:`~adaptid.models.RecursiveAR`
    (θ and its estimator's state, updated by the ``NAME_update`` below). The
    files then add ``NAME_model_t``, ``NAME_model_init``, ``NAME_model_theta``
    and ``real NAME_step(NAME_model_t *m, real y[, u])``, which keeps the lag
    buffers (zero before the first sample, MATLAB's convention), removes the
    offsets from the raw measurements, forms

    .. math::

        \varphi_k = [-(y_{k-1} - y_0), \dots, -(y_{k-n_a} - y_0),\;
                     u^{(i)}_{k-n_k^{(i)}} - u^{(i)}_0, \dots,
                     u^{(i)}_{k-n_k^{(i)}-n_b^{(i)}+1} - u^{(i)}_0, \dots]^T,

    returns :math:`\hat y_k + y_0` with :math:`\hat y_k = \varphi_k^T\hat\theta_{k-1}`
    (the one-step prediction made before :math:`y_k` is used, summed in the
    order of NumPy's pairwise sum as ``RecursiveARX.step`` sums it), and for a
    streaming object updates θ with :math:`(\varphi_k, y_k - y_0)`. The
    header documents the regressor in a comment and in named constants
    (``NAME_NA``, ``NAME_NB_i``, ``NAME_NK_i``, ``NAME_PHI_U_i``, ``NAME_Y0``,
    ``NAME_U0_i``, ``NAME_START``). The predictor is the ARX model's linear
    regression form (Ljung (1999), sec. 4.2; MATLAB's ``recursiveARX``
    ``step``). See ``docs/embedded.md``, "C for a model".

    The generated code is C99 without dynamic memory or recursion, using only
    ``<math.h>``, ``<stdint.h>`` and ``<string.h>``; n (and the window M)
    are fixed at generation. The header declares

    * ``NAME_t`` — θ, the U-D factors of P, counters (and the window buffer);
      for LMS / NLMS θ and the counters only (no covariance);
    * ``void NAME_init(NAME_t *s)`` — the estimator's state at export time;
    * ``double NAME_update(NAME_t *s, const double phi[N], double y)`` — one
      sample; returns the a-priori error :math:`\varepsilon = y - \varphi^T\theta`
      and skips (counts in ``n_skipped``) a sample with NaN or inf, as
      ``nan_policy="skip"`` does;
    * ``double NAME_predict(const NAME_t *s, const double phi[N])``,
      ``void NAME_theta(const NAME_t *s, double theta[N])``.

    With ``dtype="float32"`` every ``double`` is ``float``. The update mirrors
    the compiled kernel's operations in the same order: the U-D measurement
    update of Bierman (1977, ch. V), forgetting as ``D ← D/λ`` before it,
    the sliding window's add-then-remove of Yamamoto (1991, eqs. 62–65), the
    Kalman time update of Ljung & Söderström (1983, eq. 2.114). An RLS in the
    square-root or covariance form (``form="auto"`` is the square root for
    16 ≤ n ≤ 64) is exported from its state converted to U-D, exact up to rounding:
    the C code then continues the U-D recursion.

    .. math::

        K_k = \frac{P_{k-1}\varphi_k}{r + \varphi_k^T P_{k-1}\varphi_k},\quad
        \theta_k = \theta_{k-1} + K_k\varepsilon_k,\quad
        P_k = P_{k-1} - K_k\varphi_k^T P_{k-1}.

    LMS and NLMS (MATLAB ``recursiveLS`` ``Gradient`` / ``NormalizedGradient``;
    Widrow & Stearns 1985, eq. 6.3; Haykin 2002, eq. 6.44) follow
    :mod:`adaptid._kernels.recursions._lms`: the same dot products (four partial sums
    for n ≥ 8), the same test for non-finite samples, weight w = 1:

    .. math::

        \theta_k = \theta_{k-1} + \mu\,w\,\varphi_k\varepsilon_k
        \quad\text{(LMS)},\qquad
        \theta_k = \theta_{k-1}
            + \frac{\mu\,w}{\epsilon_0 + \varphi_k^T\varphi_k}\,\varphi_k\varepsilon_k
        \quad\text{(NLMS)};

    a non-finite error on finite data or a non-finite θ (the step is too
    large; Python's ``DivergenceWarning``) sets ``NAME_FLAG_DIVERGED`` in
    ``flags``.

    Every product the kernel fuses (numba's ``fastmath={"contract"}``) is
    written ``FMA(a, b, c)``: compiled with ``-DNAME_USE_FMA`` on a CPU with a
    hardware FMA (x86-64 with ``-mfma``) and ``-ffp-contract=off`` (the default
    of ``-std=c99``), the trajectory is bit for bit that of ``run``; without
    it, the product is rounded first and the results agree to rounding
    (≤ 1e-12 relative; see ``docs/embedded.md``).

    Parameters
    ----------
    est : RLS, SlidingWindowRLS, KalmanRLS, LMS, NLMS, FastRLS; ARX, AR, RecursiveARX or RecursiveAR; NARX or RecursiveNARX
        Single stream and single output. A :class:`~adaptid.FastRLS`
        (either method) gets its own interface, ``NAME_update(s, u, y)``
        taking the new raw input sample, ``NAME_predict(s, u)`` and, when θ
        is held, ``NAME_theta`` (the lattice solves
        :math:`R\theta = z` by back substitution on request; see
        :mod:`adaptid.codegen._fastrls` and :mod:`adaptid.codegen._fastlattice`,
        ``docs/models/fastrls.md``).
        A NARX predictor: ``NAME_step`` with its lag buffers
        (:mod:`adaptid.codegen._narx`). RLS forgetting: a constant λ (with or
        without ``P_max``), ``Exponential``, ``Directional``, ``ConstantTrace``
        or ``Variable``. Samples have weight 1 and the constant λ. A model:
        single output; a streaming object with a finite ``P0``.
    directory : str or os.PathLike
        Created if missing.
    name : str
        C identifier used as the file name and the prefix of every symbol.
    dtype : {"float64", "float32"}
    offsets : float or tuple (y0, u0), optional
        Models only: the offsets removed from the raw output and inputs
        (``u0`` a number or one per input). Default: for an ARX / AR fitted
        on an :class:`~adaptid.models.IDData` detrended with ``"constant"``,
        the means it removed (a ValueError for a ``"linear"`` trend); else 0.
    nk : int
        :class:`~adaptid.FastRLS` only: an input delay of nk samples before the
        delay line, :math:`\varphi_k = [v_k, \dots, v_{k-n+1}]^T` with
        :math:`v_k = u_{k-n_k}`; the generated ``NAME_update`` takes the raw
        :math:`u_k` and keeps the nk inputs not yet in the line.
    pending : array_like, shape (nk,), optional
        :class:`~adaptid.FastRLS` only: those nk raw inputs at export, oldest
        first (default zeros: the prewindowed start).

    Returns
    -------
    tuple of pathlib.Path
        The paths of ``NAME.h`` and ``NAME.c``.

    See Also
    --------
    adaptid.models.NARX : a fitted NARX (or a
        :class:`~adaptid.models.RecursiveNARX`) given as ``est`` is exported as
        its predictor, ``void NAME_step(NAME_t *s, const real *y, const real *u,
        real *yhat)``: lag buffers and the selected terms with the fitted θ
        (one-step prediction, or a free run with ``y = NULL``), bit for bit
        ``predict`` / ``simulate`` in double precision with ``-ffp-contract=off``
        (``docs/models/nonlinear.md``).

    Examples
    --------
    >>> import tempfile, numpy as np, adaptid
    >>> from adaptid.codegen import to_c
    >>> est = adaptid.RLS(2, forgetting=0.99)
    >>> _ = est.run(np.ones((3, 2)), np.ones(3))
    >>> h, c = to_c(est, tempfile.mkdtemp(), name="motor")
    >>> "double motor_update(motor_t *s, const double phi[MOTOR_N], double y);" in h.read_text()
    True
    >>> from adaptid.models import RecursiveARX
    >>> h, c = to_c(RecursiveARX(2, 2, 3), tempfile.mkdtemp(), name="dryer",
    ...             offsets=(20.0, 5.0))
    >>> "phi[2] = +(u(k-3) - DRYER_U0_0)" in h.read_text()
    True
    """
    from ._model import generate_model, is_model
    if (nk != 0 or pending is not None) and type(est).__name__ != "FastRLS":
        from .._validation import param_error
        raise param_error("nk", "0 (and pending None) except for a FastRLS (the input delay "
                          "of its delay line)", nk)
    if is_model(est):
        from ._generate import write_texts
        texts = generate_model(est, name=name, dtype=dtype, offsets=offsets)
        return write_texts(texts, directory, name)
    if offsets is not None:
        from .._validation import param_error
        raise param_error("offsets", "None for an estimator (offsets apply to an ARX/AR "
                          "model or streaming object)", offsets)
    from ._narx import is_narx, write_narx
    if is_narx(est):  # a NARX predictor (codegen/_narx.py), not an estimator's recursion
        return write_narx(est, directory, name=name, dtype=dtype)
    if type(est).__name__ == "FastRLS":  # the delay-line filter: its own generator (issue 38)
        from . import _fastrls
        return _fastrls.write(est, directory, name, dtype, nk, pending)
    if not hasattr(est, "get_state"):
        from .._validation import param_error
        raise param_error("est", "an adaptid RLS, SlidingWindowRLS, KalmanRLS, LMS or NLMS",
                          est, exc=TypeError)
    state = est.get_state()
    if getattr(est, "form", "ud") != "ud":  # RLS in the square-root / covariance form
        state = type(est).from_state(state, form="ud").get_state()
    return write(state, directory, name=name, dtype=dtype)


def generate_c(state, *, name="rls", dtype="float64"):
    """The texts ``(header, source)`` of :func:`to_c` for a ``get_state()`` dict."""
    return generate(state, name=name, dtype=dtype)

