"""Tests of adaptid.codegen: the generated C against the library's own runs."""
