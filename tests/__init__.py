"""adaptid's tests: one folder per package of src/adaptid (see conftest.py)."""
