"""The mcpt command line: a thin click layer over the mcpt library (one module per command)."""
