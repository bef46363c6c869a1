"""Benchmarks of control_ncs against its alternatives.

``python -m benchmarks`` (about 30 minutes on the project's 2-core machine:
sections 1-6 took 14 min in one measured run, the sweeps section 9 min, the
Markov and estimator sections 2.5-5 min) writes ``docs/benchmarks.md`` and ``docs/benchmarks_scaling.png``;
``python -m benchmarks --quick`` runs every section at tiny sizes (seconds).

Modules: ``common`` (seeded plants, timing, memory-capped subprocesses,
versions), ``worker`` (the subprocess side), ``bench_synthesis`` (§1, §2),
``bench_stability`` (§3), ``bench_simulate`` (§4), ``bench_passivity``
(§5), ``report`` (tables), ``notes`` (the analysis appended to the report).
"""
