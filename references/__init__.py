"""Independent references that the tests and the benchmarks share, outside the package.

Each is derived without the code it checks: the degree-8 closed form of the 3-RRR platform
(:mod:`references.peers_closed_form`), its roots to 50 digits (:mod:`references.reference_roots`), the
edge campaign's exact references (:mod:`references.edge_references`), and seeded random designs
(:mod:`references.random_designs`, :mod:`references.graph_designs`).
"""
