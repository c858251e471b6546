"""Tests of adaptid.constrained: constrained least squares, its applications, ConstrainedRLS."""
