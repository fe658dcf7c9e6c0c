"""The stability suite: numerical extremes (:mod:`.extreme`) and hostile input and faults (:mod:`.faults`).

Every case is a function returning rows that state what was measured, the criterion and whether
it held. ``tests/test_extreme.py`` and ``tests/test_stability.py`` assert the criteria;
``python -m tests.stability.report`` runs the same functions and writes ``docs/stability.md``.
"""
