r"""Several experiments in one :class:`~adaptid.IDData` (MATLAB's ``merge``)."""

from __future__ import annotations

import numpy as np

from .._validation import param_error

__all__ = ["ExperimentsMixin"]


class ExperimentsMixin:
    """The experiments of a record: ``merge``, ``n_experiments``, ``experiment(k)``.

    A merged record keeps its experiments as single-experiment records in
    ``_parts`` (None for one experiment) over the concatenated signals.
    """

    _parts = None

    # ------------------------------------------------------- experiments
    def merge(self, *others):
        r"""Several experiments as one record (MATLAB's ``merge``), kept apart.

        The samples are concatenated (``len`` is the total, ``outputs`` /
        ``inputs`` the stacked signals), but every function that forms
        regressors or data matrices forms them inside each experiment,
        never across the boundary between two of them: the ARX rows of a
        merged record are the rows of each experiment stacked, the filters
        of the prediction-error models restart at each experiment, and so do
        ``compare``, ``resid``, ``n4sid`` (see the user guide's page on
        experiments).

        Parameters
        ----------
        *others : IDData
            Records with the same output and input names and the same
            ``dt`` (to a relative 1e-9) as this one; merged records are
            expanded into their experiments.

        Returns
        -------
        IDData
            With :attr:`n_experiments` the number of experiments.

        Raises
        ------
        ValueError
            If a record has other signal names or another ``dt`` (the
            message names ``others[i]``).
        TypeError
            If one of ``others`` is not an IDData.

        Examples
        --------
        >>> import numpy as np
        >>> from adaptid import IDData
        >>> d = IDData(np.ones(5), np.zeros(5)).merge(IDData(np.ones(3), np.zeros(3)))
        >>> d.n_experiments, len(d), len(d.experiment(1))
        (2, 8, 3)
        """
        parts = list(self.experiments)
        for i, other in enumerate(others):
            if not isinstance(other, type(self)):
                raise param_error(f"others[{i}]", "an IDData", other, exc=TypeError)
            if (other.y_names, other.u_names) != (self.y_names, self.u_names):
                raise param_error(f"others[{i}]", f"a record with outputs {list(self.y_names)} "
                                  f"and inputs {list(self.u_names)} (as the first)",
                                  f"<outputs {list(other.y_names)}, inputs {list(other.u_names)}>")
            if abs(other.dt - self.dt) > 1e-9 * self.dt:
                raise param_error(f"others[{i}]", f"a record with dt={self.dt:g} (as the first)",
                                  f"<dt={other.dt:g}>")
            kinds = {None if p.time is None else p.time.dtype.kind in "Mm" for p in parts}
            theirs = None if other.time is None else other.time.dtype.kind in "Mm"
            if theirs is not None and None not in kinds and theirs not in kinds:
                raise param_error(f"others[{i}]", "time stamps of the same kind as the first "
                                  "(all datetime/timedelta or all numbers)", "<another kind>")
            parts.extend(other.experiments)
        return _merged(parts)

    @property
    def n_experiments(self) -> int:
        """Number of experiments (1 unless the record comes from :meth:`merge`)."""
        return 1 if self._parts is None else len(self._parts)

    @property
    def experiments(self) -> list:
        """The experiments as single-experiment :class:`IDData` records (a list)."""
        return [self] if self._parts is None else list(self._parts)

    def experiment(self, k):
        """Experiment ``k`` (0-based) as an :class:`IDData`.

        Parameters
        ----------
        k : int
            0 ≤ k < :attr:`n_experiments`.

        Returns
        -------
        IDData
        """
        from .._validation import check_int

        k = check_int(k, "k", low=0, high=self.n_experiments - 1)
        return self.experiments[k]

    @property
    def bounds(self) -> np.ndarray:
        """Sample offsets of the experiments, shape (n_experiments + 1,): experiment e is
        the samples ``bounds[e] … bounds[e+1] − 1`` of :attr:`outputs`."""
        return np.concatenate([[0], np.cumsum([len(p) for p in self.experiments])]).astype(np.int64)


def _merged(parts):
    """One IDData holding the single-experiment records ``parts`` (no checks)."""
    if len(parts) == 1:
        return parts[0]
    first = parts[0]
    new = object.__new__(type(first))
    new._parts = tuple(parts)
    new.outputs = np.ascontiguousarray(np.concatenate([p.outputs for p in parts]))
    new.inputs = np.ascontiguousarray(np.concatenate([p.inputs for p in parts]))
    new.y_trend = np.concatenate([p.y_trend for p in parts])
    new.u_trend = np.concatenate([p.u_trend for p in parts])
    new.dt, new._k0 = first.dt, 0
    new.y_names, new.u_names = first.y_names, first.u_names
    new.time = None
    return new
