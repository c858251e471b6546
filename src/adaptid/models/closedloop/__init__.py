r"""Closed-loop identification: a feedback test and the indirect and two-stage methods.

* :func:`checkfeedback` — is there feedback from y to u in a record?
  (residuals of a high-order ARX against future inputs; MATLAB's
  ``feedback``), a :class:`FeedbackResult`;
* :func:`indirect` — the indirect method with a known controller
  (Ljung 1999, sec. 13.5);
* :func:`two_stage` — the two-stage (projection) method of Van den Hof and
  Schrama (Forssell and Ljung 1999).

The direct prediction-error method needs nothing new: fit :class:`ARX`,
:class:`ARMAX` or :class:`BJ` to the closed-loop (y, u); see the page
"Closed-loop identification" of the documentation.
"""

from ._feedback import FeedbackResult, checkfeedback
from ._indirect import indirect, two_stage

__all__ = ["checkfeedback", "FeedbackResult", "indirect", "two_stage"]
