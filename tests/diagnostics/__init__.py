"""Tests of adaptid.diagnostics: residual checks and the structural-change tests."""
