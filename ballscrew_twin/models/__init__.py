"""Models of the ball screw that share one interface (:mod:`ballscrew_twin.models.base`).

- :mod:`.catalog`: catalogue formulas, Eqs. 51 and 52 (no physics of the contacts).
- :mod:`.steady`: quasi-static equilibrium of every loaded sphere with the lubricated
  contact laws of the paper (:mod:`.contact_forces`); its parts :mod:`.steady_types`,
  :mod:`.steady_problem`, :mod:`.steady_reference`, :mod:`.steady_compiled`,
  :mod:`.steady_continuation` and :mod:`.steady_output`.
- :mod:`.steady_map`, :mod:`.realtime`: the steady model tabulated, and the real-time model
  that steps through that table (what the node runs).
- :mod:`.dynamic`: every sphere in 6 DOF (:mod:`.faults`, :mod:`.sphere_contact`); run by
  :mod:`.simulation` from :mod:`.scenario` files.
- :mod:`.validity`: validity envelope; clamped values with warnings, never garbage.
"""
