"""Symbolic verification of the paper's claims (sympy), with an errata report.

The per-claim checks and ``python -m verification`` arrive with the verification issue; the
foundation's own symbolic checks of Prop. 1, Prop. 2, Cor. 1-2 and Eq. (10) live in
``tests/test_closure.py`` until then.
"""
