"""The chart builders: each draws one chart of docs/PERFORMANCE.md from its benchmark's results file.

``python3 benchmarks/charts [--out DIR]`` (``__main__.py``, the DVC ``charts`` stage) draws them all; a benchmark
that draws its own chart imports its builder (``from charts.agreement import chart_agreement``). Each module can
also be run as a file, ``python3 benchmarks/charts/<name>.py [results.json [out.png]]``.
"""
