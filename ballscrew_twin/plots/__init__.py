"""Figures people look at, shared by several commands (Figure API, Agg canvas, no pyplot).

Axes carry their units; torques are shown in mN m (the human unit), everything else SI or its
usual multiple (nm, deg, mN m) named on the axis.
"""
