"""Tests of adaptid.continuous: continuous-time laws and their discretisation."""
