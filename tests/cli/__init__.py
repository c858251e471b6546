"""Tests of adaptid.cli: the command line, its report and its compiled-at-install prewarm."""
