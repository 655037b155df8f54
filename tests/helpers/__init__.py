"""Helper modules the tests share (importable as ``helpers.<module>``: ``pythonpath`` includes
``tests/``)."""
