"""The SIMD lanes: structure-of-arrays kernels that advance many streams at once.

``_soa`` runs batches of RLS streams (U-D and covariance forms) eight at a time
in lock-step, bit for bit the scalar kernels of ``recursions/``; ``_soa_ud``
and ``_soa_cov`` are the per-form steps, ``_soa_forms`` selects between them,
``_soa_lanes`` holds the shared lane helpers.
"""
