"""Models of the ball screw that share one interface (:mod:`ballscrew_twin.models.base`).

- :mod:`.catalog`: catalogue formulas, Eqs. 51 and 52 (no physics of the contacts).
- :mod:`.steady`: quasi-static equilibrium of every loaded sphere with the lubricated
  contact laws of the paper.
"""
