"""Tests of adaptid.models: model objects, regressor builders and the identification workflow."""
