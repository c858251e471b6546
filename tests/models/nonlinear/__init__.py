"""Tests of adaptid.models.nonlinear (issue 35)."""
