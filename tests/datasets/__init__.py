"""Tests of adaptid.datasets: the packaged data sets and the examples built on them."""
