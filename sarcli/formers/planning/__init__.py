"""What a former costs and which one ``--method auto`` picks.

- :mod:`.planner`: the candidates predicted to meet a tolerance and auto's pick; the calibration
  of the cost model's constants;
- :mod:`.cost`: one memory and one time model per family, and the knobs' ranges;
- :mod:`.calibration`: the constants, per machine (``cost_model.json``: the reference machine's).

The modules are imported by name (``from sarcli.formers.planning import planner``): the options
(:mod:`sarcli.formers.options`) read the ranges of :mod:`.cost` while the planner reads the options.
"""
