"""mcpt's benchmarks: timing sweeps, error against run time, plots and a Markdown report.

Run ``bench/run.py --quick`` (what ``make bench`` does) or ``mcpt bench``; see bench/suite.py.
"""
