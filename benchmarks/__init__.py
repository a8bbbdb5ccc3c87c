"""benchmarks/ as a package: the tests import its scripts (`from benchmarks import ...`) and its scripts import each other; run a script from the repository root as `python -m benchmarks.<name>`."""
