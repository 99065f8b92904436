"""Iteration limits and tolerances shared by the readable solvers and their compiled kernels.

The steady-state Newton solver (:mod:`ballscrew_twin.models.steady`, compiled in
:mod:`ballscrew_twin.kernels.steady_solver`) and the dynamic model's backward-Euler step
(:mod:`ballscrew_twin.models.dynamic`, compiled in :mod:`ballscrew_twin.kernels.dynamic_step`)
must use the same numbers in both forms. They are defined once, here, below the models: numba
freezes them into each kernel's cached machine code, and the kernels' dependency stamps
(:mod:`ballscrew_twin.kernels.cache_stamp`) hold their values, so a change here recompiles.
"""

from __future__ import annotations

# ----------------------------------------------------------------------------- steady state
NEWTON_MAX_ITER = 80
LINE_SEARCH_STEPS = 12
MIN_STEP = 1e-3  # shortest line-search step, taken even without decrease
DIAGONAL_SHIFT = 1e-12  # relative regularisation of the sphere blocks

# ----------------------------------------------------------------------------- dynamic step
VELOCITY_STEP = 1e-7  # m/s and rad/s x r_b: finite-difference step of the velocity Jacobian
HELIX_NEWTON_STEPS = 3  # Newton iterations locating each sphere on the helix (Eq. 4)
STEP_NEWTON_MAX = 10  # Newton iterations of one backward-Euler step at most
STEP_TOLERANCE = 1e-6  # scaled residual of the step equations that ends the iterations
STEP_BACKTRACKS = 4  # halvings of a Newton correction that would raise the residual
#: Within a step the Jacobian is re-evaluated at the iterate only when the last iteration
#: reduced the scaled residual by less than this factor (0: at every iterate, plain Newton).
JACOBIAN_REFRESH_RATIO = 0.1
#: Newton's first guess: the velocities extrapolated from the starts of the last steps by a
#: polynomial of order up to this (0: the last velocities), the order that predicted the last
#: step best; a guess that already meets STEP_TOLERANCE ends the step without a correction.
PREDICTOR_ORDER = 3
