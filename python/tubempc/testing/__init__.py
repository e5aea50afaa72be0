"""Test support shipped with the package, not part of its API (docs/layout.md): independent oracles and
harnesses that tests and benchmarks use to check the product.

- :mod:`.identification`: a numpy forgetting-factor identifier, the oracle the C++ one is tested against;
- :mod:`.examples`: the built C++ example programs (``examples/cpp/``);
- :mod:`.fuzz`: the fuzz harness of the scenario-file reader and the configuration (``tubempc bench fuzz``).
"""
