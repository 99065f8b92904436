"""Compiled (numba) kernels of the model's hot loops.

Each kernel mirrors a readable numpy reference elsewhere in the package and is tested against it:

- :mod:`ballscrew_twin.kernels.contacts`: every ball-groove contact law, the compiled twin of
  :func:`ballscrew_twin.models.contact_forces.evaluate_contacts`.
- :mod:`ballscrew_twin.kernels.steady_solver`: the steady state's Newton solve, structured per
  sphere with exact Jacobian blocks by forward mode (:mod:`ballscrew_twin.kernels.dual`), the
  compiled twin of ``models.steady_reference.ReadableNewton``.
- :mod:`ballscrew_twin.kernels.dynamic_step`: one time step of the dynamic model, the compiled
  twin of ``DynamicModel._step``.
- :mod:`ballscrew_twin.kernels.map_sample`: the real-time map's interpolation, the compiled twin
  of ``SteadyMap._interpolate_reference``.
"""
