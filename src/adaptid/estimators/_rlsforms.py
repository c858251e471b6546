r"""The three forms of RLS's covariance: U-D, square root (Potter) and covariance.

``RLS(form=...)`` chooses how P is propagated when the forgetting is plain
exponential (no strategy, no ``P_max``; those run on the U-D factors only):

* ``"ud"`` — :math:`P = U\,\mathrm{diag}(D)\,U^T` (Bierman), :mod:`adaptid._kernels.recursions._rls`;
* ``"sqrt"`` — :math:`P = S S^T`, S full n × n (Potter),
  :mod:`adaptid._kernels.recursions._potter`: one vectorised sweep over S per sample;
* ``"covariance"`` — P itself, exactly symmetric (MATLAB ``recursiveLS``
  arithmetic), with a definiteness monitor that repairs P,
  :mod:`adaptid._kernels.recursions._covariance`;
* ``"auto"`` (default) — U-D for n ≤ :data:`AUTO_SQRT_ABOVE` (15), for n above
  :data:`FORMS_SPECIALISED_N` (64) and for an exact diffuse start, the
  square-root form in between (the faster one at each n,
  ``benchmarks/bench_rls_forms.py``).

The state vector keeps one length for all forms, ``[θ | n·n block | n]``: U by
columns and D; S by columns and zeros; P and zeros.

Conversions (exact up to rounding, no inverse formed) go through the upper
triangular T with :math:`T T^T = P`:

* U-D → T = U diag(√D);
* S → T from the QR factorisation :math:`S^T J = Q R` (J the reversal):
  :math:`T = J R^T J`;
* P → T from the Cholesky factor of :math:`J P J` (as :func:`._factor.ud_from_P`);
* T → U-D: :math:`D_j = T_{jj}^2`, :math:`U = T\,\mathrm{diag}(1/T_{jj})`; T → S: S = T;
  T → P: :math:`T T^T`, symmetrised.
"""

from __future__ import annotations

import copy as _copy

import numpy as np

from .._validation import check_choice, param_error

__all__ = ["FORMS", "AUTO_SQRT_ABOVE", "resolve_form", "block_from_T", "T_from_block",
           "P_from_block", "ud_from_block", "convert_state"]

FORMS = ("auto", "ud", "sqrt", "covariance")
#: ``form="auto"`` takes the square-root form for n above this; None: never.
#: ``benchmarks/bench_rls.py --forms`` shows the choice: since the vectorised Potter
#: sweep the square-root form is the faster from n = 16 to 64, the two tie at
#: n = 10..14, so the switch is at n >= 16. Above FORMS_SPECIALISED_N both forms are
#: the run-time-n kernels, and there U-D is the faster and compiles sooner: "auto"
#: is U-D again from n = 65 on. An exact diffuse start
#: (``P0="diffuse"``) stays in U-D (it hands over to U-D factors); ``run(stats=True)``
#: continues an estimator in U-D form (:meth:`FormsMixin._before_stats`).
AUTO_SQRT_ABOVE = 15


def resolve_form(form, n, fast, diffuse=False):
    """The form an RLS of n parameters runs in ("ud", "sqrt" or "covariance");
    "auto" is U-D with an exact diffuse start (``diffuse``: it hands over to U-D)."""
    form = check_choice(form, "form", FORMS)
    if not fast:
        if form in ("sqrt", "covariance"):
            raise param_error("form", "'ud' or 'auto' with a forgetting strategy or P_max "
                              "(they act on the U-D factors)", form)
        return "ud"
    if form == "auto":
        big = AUTO_SQRT_ABOVE is not None and AUTO_SQRT_ABOVE < n <= FORMS_SPECIALISED_N
        return "sqrt" if big and not diffuse else "ud"
    return form


#: the covariance and square-root forms are compiled for each n up to this (n a
#: compile-time constant: LLVM keeps u and c in vector registers across the fused
#: sweep, as gcc does for the C loop ``rls_fu_nN``, and the Potter sweep's work
#: arrays are on the stack); larger n use the generic kernel. The U-D form follows
#: ``adaptid._config.MAX_SPECIALISED_N``.
FORMS_SPECIALISED_N = 64


def ntag_for(form, n, tag):
    """The size tag of an RLS in ``form`` (the engine's ``tag`` unless specialised here)."""
    import os
    if form not in ("covariance", "sqrt") or not isinstance(tag, int) \
            or n > FORMS_SPECIALISED_N or os.environ.get("NUMBA_DISABLE_JIT") == "1":
        return tag
    return (0,) * n


def _cols(block, n):
    """The n × n matrix stored by columns in ``block`` (…, n·n)."""
    return np.swapaxes(block.reshape(block.shape[:-1] + (n, n)), -1, -2)


def _upper(T):
    n = T.shape[-1]
    out = T.copy()
    out[..., np.tril_indices(n, -1)[0], np.tril_indices(n, -1)[1]] = 0.0
    return out


def T_from_block(block, form, n):
    """Upper triangular T with T Tᵀ = P from a state's covariance block (…, n·n + n)."""
    M = _cols(block[..., : n * n], n)
    if form == "ud":
        D = block[..., n * n:]
        return _upper(M) * np.sqrt(D)[..., None, :]
    if form == "sqrt":
        R = np.linalg.qr(M.swapaxes(-1, -2)[..., :, ::-1], mode="r")
        return _upper(R.swapaxes(-1, -2)[..., ::-1, ::-1])
    L = np.linalg.cholesky(M[..., ::-1, ::-1])
    return _upper(L[..., ::-1, ::-1])


def block_from_T(T, form):
    """The covariance block (…, n·n + n) of ``form`` for P = T Tᵀ."""
    n = T.shape[-1]
    lead = T.shape[:-2]
    tail = np.zeros(lead + (n,))
    if form == "ud":
        t = np.diagonal(T, axis1=-2, axis2=-1)
        M = T / t[..., None, :]
        M = _upper(M)
        idx = np.arange(n)
        M[..., idx, idx] = 1.0
        tail = t * t
    elif form == "sqrt":
        M = T
    else:
        M = T @ T.swapaxes(-1, -2)
        M = 0.5 * M + 0.5 * M.swapaxes(-1, -2)
    return np.concatenate([M.swapaxes(-1, -2).reshape(lead + (n * n,)), tail], axis=-1)


def P_from_block(block, form, n):
    """P (…, n, n), exactly symmetric, from a covariance block."""
    M = _cols(block[..., : n * n], n)
    with np.errstate(over="ignore", invalid="ignore"):
        if form == "sqrt":
            P = M @ M.swapaxes(-1, -2)
        elif form == "covariance":
            P = M.copy()
        else:
            D = block[..., n * n:]
            P = M @ (D[..., :, None] * M.swapaxes(-1, -2))
    return 0.5 * P + 0.5 * P.swapaxes(-1, -2)


def ud_from_block(block, form, n):
    """(U, D) of the covariance block (views for the U-D form, new arrays otherwise)."""
    if form == "ud":
        return _cols(block[..., : n * n], n), block[..., n * n:]
    b = block_from_T(T_from_block(block, form, n), "ud")
    return _cols(b[..., : n * n], n), b[..., n * n:]


def convert_state(state: dict, form) -> dict:
    """A :meth:`RLS.get_state` dict with its covariance block in ``form``."""
    out = _copy.deepcopy(state)
    opts = out["options"]
    n, p = int(out["n_params"]), int(out["n_outputs"])
    src = opts.get("form", "ud")
    fast = isinstance(opts.get("forgetting", 1.0), float) and opts.get("P_max") is None
    dst = resolve_form(form, n, fast)
    opts["form"] = dst
    if src == dst:
        return out
    S = np.array(out["state"], dtype=np.float64)
    blk = S[..., n * p:]
    try:
        T = T_from_block(blk, src, n)
    except np.linalg.LinAlgError:
        raise param_error("state", f"a positive definite covariance to convert to form={dst!r}",
                          "<an indefinite P>") from None
    S[..., n * p:] = block_from_T(T, dst)
    out["state"] = S
    return out


class FormsMixin:
    """What :class:`~adaptid.RLS` adds to the engine for its forms (state layout, P, warnings)."""

    @property
    def form(self) -> str:
        """The form P is propagated in: "ud", "sqrt" or "covariance" ("auto" resolved)."""
        return self._form

    def _fill_initial(self, S):
        super()._fill_initial(S)
        n, p = self.n_params, self.n_outputs
        if self._form == "covariance":  # P0 itself, not re-formed from its factors
            S[n * p:] = np.concatenate([self.P0.T.ravel(), np.zeros(n)])
        elif self._form == "sqrt":
            S[n * p:] = block_from_T(T_from_block(S[n * p:], "ud", n), "sqrt")

    def _covariance_of(self, S):
        if self._form == "ud":  # the engine's (it knows the diffuse tail after the factors)
            return super()._covariance_of(S)
        n, p = self.n_params, self.n_outputs
        return P_from_block(S[..., n * p:], self._form, n)

    def _ud_views(self, S):
        if self._form == "ud":
            return super()._ud_views(S)
        n, p = self.n_params, self.n_outputs
        return ud_from_block(S[..., n * p:], self._form, n)

    def _warn_repairs(self, codes, where):
        codes = np.atleast_1d(codes)
        rep = codes <= -2
        if self._form != "covariance" or not rep.any():
            return codes
        first = int(np.argmax(rep))
        at = -2 - int(codes[first])
        self._warn_definiteness(at if where is None else f"{at} of {where} {first}",
                                int(rep.sum()) if where is not None else None)
        return np.where(rep, -1, codes)

    def _warn_definiteness(self, at, count=None):
        from .._exceptions import DefinitenessLossWarning
        import warnings
        streams = f" ({count} {'streams' if count > 1 else 'stream'})" if count else ""
        warnings.warn(
            f"{type(self).__name__}(form='covariance'): P lost positive definiteness in "
            f"rounding at sample {at}{streams}; it was repaired (modified LDLᵀ, pivots raised "
            "to eps·max diag P). Poorly excited data with strong forgetting? The U-D or "
            "square-root form keeps P definite by construction", DefinitenessLossWarning,
            stacklevel=5)

    def _report_codes(self, codes, where):
        super()._report_codes(self._warn_repairs(codes, where), where)

    def _warn_segments(self, status):
        super()._warn_segments(self._warn_repairs(status, "segment"))

    def _warn_rebuild(self, count):
        if self._form != "covariance":
            return super()._warn_rebuild(count)
        return self._warn_definiteness(self.n_updates)

    def _before_stats(self):
        """``run(stats=True)`` computes the statistics in the U-D stream: an estimator in
        the square-root form (``form="auto"`` above n = :data:`AUTO_SQRT_ABOVE`) continues
        in the U-D form from here on, its state converted (exact up to rounding)."""
        if self._form == "sqrt":
            other = type(self).from_state(self.get_state(), form="ud")
            self.__dict__.update(other.__dict__)

    def to_c(self, directory, *, name="rls", dtype="float64"):
        """The C export runs the U-D form: other forms are exported from their state
        converted to U-D (exact up to rounding; the C code then equals the U-D form's
        recursion, not this form's, bit for bit)."""
        if self._form == "ud":
            return super().to_c(directory, name=name, dtype=dtype)
        other = type(self).from_state(self.get_state(), form="ud")
        return other.to_c(directory, name=name, dtype=dtype)

    @classmethod
    def from_state(cls, state: dict, *, form=None):
        """Rebuild an estimator from :meth:`get_state`'s dict (exact round trip).

        ``form`` ("auto", "ud", "sqrt", "covariance"): convert the state's
        covariance to that form first (exact up to rounding; see
        :mod:`adaptid.estimators._rlsforms`). None keeps the state's form.
        """
        if form is not None and isinstance(state, dict) and state.get("estimator") == cls.__name__:
            try:
                state = convert_state(state, form)
            except (KeyError, TypeError, AttributeError, IndexError) as err:
                raise param_error("state", "a complete dict from get_state()",
                                  f"<{type(err).__name__}: {err}>") from None
        return super().from_state(state)
