"""The common record of one recursive algorithm's compiled entry points."""

from typing import NamedTuple

__all__ = ["Entries"]


class Entries(NamedTuple):
    """The compiled entry points of one algorithm (one signature for all).

    ``step`` (RLS's fast forms only, else None) takes one packed sample
    (:mod:`._step`); ``update`` calls it only when that costs no compilation
    (compiled at install, or already cached) and otherwise runs a run of length 1
    through ``run``, with arguments of the types ``run`` is given
    (:meth:`adaptid.estimators._engine.RecursiveEstimator.update`). Either way a
    step is bit for bit a step of ``run``.
    """

    run: object
    run_batched: object
    run_segments: object
    step: object = None
