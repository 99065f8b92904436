"""Pure physical laws on numpy arrays, SI units, one module a topic.

- :mod:`.geometry`: helix, Frenet frame, gothic-arch half grooves, curvatures (paper 2.1)
- :mod:`.hertz`: Hertz point contact (paper 2.2, Eqs. 17-21)
- :mod:`.lubricant`: viscosity and density of the oil (Eqs. 24-25)
- :mod:`.film`: EHL film thickness and Tallian parameter (Eqs. 26-33, 38)
- :mod:`.traction`: lubricant shear, load share, sliding friction (Eqs. 34-37)
- :mod:`.rolling`: rolling resistance and friction moments (Eqs. 39-45)
"""
