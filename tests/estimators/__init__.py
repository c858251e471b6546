"""Tests of adaptid.estimators: the recursive estimators, their state files, the contract."""
