"""Fleet scale: the same identification over thousands of devices, on Dask.

* :func:`identify` — one recursive estimator (RLS, sliding window, Kalman)
  run on every group (device) of a pandas / dask DataFrame or Parquet data
  set, as one Dask computation over a compiled segmented kernel; one row of
  results per device (θ, standard errors, residual RMS, a CUSUM change flag);
* :func:`fit_models` — a model object of :mod:`adaptid.models` fitted in
  batch on every device (ARX, AR by least squares; ARMA, ARMAX, OE, BJ by
  prediction errors), or a streaming pseudo-linear object
  (``RecursiveARMAX`` …) run on every device, one Dask task per partition of
  whole devices; the same per-device table;
* :func:`lstsq` — batch least squares of a tall dask array (taller than
  memory) by a tall-skinny QR, equal to :func:`adaptid.lstsq`.

Dask runs in this process by default (synchronous scheduler; the kernel is
parallel over devices); pass a ``distributed.Client`` or a scheduler address
to run on a cluster, or ``client="local"`` to start a ``LocalCluster``.
Needs the ``dask`` extra: ``pip install 'adaptid[dask]'``.
"""

from ._identify import identify
from ._models import fit_models
from ._tsqr import lstsq

__all__ = ["identify", "lstsq", "fit_models"]
