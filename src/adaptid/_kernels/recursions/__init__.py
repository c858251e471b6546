"""The recursions: one module per recursive algorithm, each with its entry table.

``_bierman`` holds the U-D (Bierman) stages every stream shares; ``_rls``,
``_strategy``, ``_kalman``, ``_window``, ``_lms`` the algorithms;
``_diffuse``, ``_diffuse_kalman`` the exact diffuse start; ``_potter``,
``_covariance`` RLS in square-root and covariance form; ``_rollstats`` the
windowed statistics; ``_step`` the packed sample of ``update``'s step entry;
``_segments`` the statistics of segment runs; ``_parallel`` the one factory
of the parallel wrappers (``run_batched``, ``run_segments``) of a ``run``.
Outside the entry tables (their data are not rows of Φ): ``_smoother``
(the Rauch–Tung–Striebel smoother and log-likelihood of ``KalmanRLS``) and
``_fastrls`` (the fast transversal filter and QR lattice of ``FastRLS``, on
a delay line). Each algorithm module declares ``ENTRIES`` (name ->
:class:`._entries.Entries`), which :mod:`adaptid._kernels` maps to its public
names.
"""
