"""Pieces shared by the C generators of :class:`adaptid.FastRLS` (:mod:`._fastrls`, the
FTF, and :mod:`._fastlattice`, the QR lattice): the header comment on the regressor,
the nk-sample input buffer, the checks of the state and of the delay."""

from __future__ import annotations

import numpy as np

from .._validation import param_error
from . import _emit

#: the header comment on the regressor and the entry points, shared by both methods
REGRESSOR_DOC = r"""
/* Regressor: phi_k = [v_k, v_(k-1), ..., v_(k-n+1)], the prewindowed delay line of
 * v_k = u_(k-NK) (NK = $UPPER_NK; v is zero before the first sample), the model
 * y_k = theta^T phi_k + e_k, theta[j] multiplying u_(k-NK-j).
 *   $name_update(s, u, y): the raw input u_k and the output y_k; $update_doc
 *       returns the a-priori error y_k - theta^T phi_k (theta before the
 *       update). A non-finite u or y: NaN returned, state untouched (u does
 *       not enter the line or the NK buffer), n_skipped + 1.
 *   $name_predict(s, u): theta^T phi of the next sample, u its raw input
 *       (with NK > 0 the line takes ubuf[0] and u is not used); nothing changes.
$theta_doc */
"""


def subst(text, values):
    """Replace every ``$key`` of ``text`` by ``values[key]``, the longest keys first."""
    for key in sorted(values, key=len, reverse=True):
        text = text.replace("$" + key, str(values[key]))
    return text


def check_delay(nk, pending):
    """(nk, pending as float64 (nk,)): the input delay and the nk raw inputs not yet in
    the line, oldest first (None: zeros, the prewindowed start)."""
    from .._validation import as_float_array, check_int

    nk = check_int(nk, "nk", low=0, high=10_000)
    if pending is None:
        return nk, np.zeros(nk)
    return nk, as_float_array(pending, "pending", shape=(nk,))


def delay_parts(name, nk, pending, dtype):
    """Substitutions of the NK-sample input buffer (empty for nk = 0: no zero-size array)."""
    if nk == 0:
        return {"nk": 0, "ubuf_field": "", "ubuf_init": "", "delay_fn": "", "delay_call": "",
                "vin": "u", "void_u": "", "update_doc": "u_k enters the line;"}
    fn = (f"/* v_k = u_(k-NK): the oldest buffered input leaves, u enters the buffer. */\n"
          f"static real delay({name}_t *s, real u)\n{{\n"
          f"    real v = s->ubuf[0];\n    int i;\n"
          f"    for (i = 0; i < {nk - 1}; i++) s->ubuf[i] = s->ubuf[i + 1];\n"
          f"    s->ubuf[{nk - 1}] = u;\n    return v;\n}}\n")
    return {"nk": nk,
            "ubuf_field": f"    real ubuf[{name.upper()}_NK];  /* raw inputs not yet in the line, "
                          "oldest first */\n",
            "ubuf_init": _emit.array(pending, dtype) + ",\n",
            "delay_fn": fn, "delay_call": "    u = delay(s, u);\n", "vin": "s->ubuf[0]",
            "void_u": "    (void)u;\n",
            "update_doc": "u_k enters the NK buffer,\n *       u_(k-NK) the line;"}


def fits_float32(values):
    """True when every value stays finite rounded to float32 (no overflow warning)."""
    with np.errstate(over="ignore"):
        return bool(np.all(np.isfinite(np.asarray(values).astype(np.float32))))


def check_state(est, dtype):
    """The float64 state of a single-stream FastRLS (refusals name ``est``)."""
    st = est.get_state()
    if st["batch"] is not None:
        raise param_error("est", "a single-stream FastRLS", "<a batch of streams>")
    S = np.asarray(st["state"], dtype=np.float64)
    if dtype == "float32" and not fits_float32(S):
        raise param_error("est", "a state within the float32 range for dtype='float32'",
                          "<values beyond float32>")
    return st, S
