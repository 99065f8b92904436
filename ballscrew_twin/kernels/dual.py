"""Forward-mode derivatives for the compiled kernels: a dual number type for numba.

A :data:`dual` number carries a value and its partial derivatives with respect to
:data:`N_PARTIALS` seeded unknowns (one sphere's six unknowns and its nut's offset in the steady
solver). Arithmetic operators, comparisons, ``abs``/``max``/``min`` and the ``math`` functions the
contact laws use are overloaded for it, so the scalar law helpers of
:mod:`ballscrew_twin.kernels.contacts` compile unchanged for dual arguments: numba types each
helper per argument type, and a float meeting a dual is converted to a dual with zero partials
(``float`` and ``dual`` unify to ``dual``). The value part is computed by the same float
operations as the plain law, so it equals the plain evaluation bit for bit; the partials follow
the chain rule exactly (no difference step). At a kink (``abs``, ``max``, ``min``, a branch) the
derivative is that of the branch taken; where a derivative is infinite (``sqrt`` at 0,
``hypot`` and ``atan2`` at the origin) it is taken as 0.

Units: a partial has the unit of the value over that of its seeded unknown.
"""

from __future__ import annotations

import math
import operator
from typing import Any

from numba import njit, types
from numba.core import cgutils
from numba.core.typeconv import Conversion
from numba.extending import (
    intrinsic,
    lower_cast,
    make_attribute_wrapper,
    models,
    overload,
    register_model,
)

#: partial derivatives carried by a dual number
N_PARTIALS = 7


class DualType(types.Type):
    """numba type of a dual number: value ``v`` (float64) and partials ``g`` (7 float64)."""

    def __init__(self) -> None:
        super().__init__(name="Dual")

    def unify(self, typingctx: Any, other: Any) -> Any:
        """A float or an integer meeting a dual (branches, loop variables) becomes a dual."""
        if isinstance(other, (types.Float, types.Integer)):
            return self
        return None

    def can_convert_from(self, typingctx: Any, other: Any) -> Any:
        if isinstance(other, (types.Float, types.Integer)):
            return Conversion.safe
        return None


dual = DualType()
PARTIALS = types.UniTuple(types.float64, N_PARTIALS)


@register_model(DualType)
class _DualModel(models.StructModel):
    def __init__(self, dmm: Any, fe_type: Any) -> None:
        super().__init__(dmm, fe_type, [("v", types.float64), ("g", PARTIALS)])


make_attribute_wrapper(DualType, "v", "v")
make_attribute_wrapper(DualType, "g", "g")


def _make_dual(typingctx: Any, value: Any, partials: Any) -> Any:
    sig = dual(types.float64, PARTIALS)

    def codegen(context: Any, builder: Any, signature: Any, args: Any) -> Any:
        number = cgutils.create_struct_proxy(dual)(context, builder)
        number.v = args[0]
        number.g = args[1]
        return number._getvalue()

    return sig, codegen


#: make_dual(value, partials): the dual number of a float64 and a 7-tuple of float64
make_dual: Any = intrinsic(_make_dual)


@lower_cast(types.Float, DualType)
@lower_cast(types.Integer, DualType)
def _number_to_dual(context: Any, builder: Any, fromty: Any, toty: Any, val: Any) -> Any:
    number = cgutils.create_struct_proxy(dual)(context, builder)
    number.v = context.cast(builder, val, fromty, types.float64)
    number.g = context.get_constant_generic(builder, PARTIALS, (0.0,) * N_PARTIALS)
    return number._getvalue()


# ----------------------------------------------------------------------------- partials
@njit(inline="always")
def _scaled(a, s):
    """s a of a partials tuple."""
    return (a[0] * s, a[1] * s, a[2] * s, a[3] * s, a[4] * s, a[5] * s, a[6] * s)


@njit(inline="always")
def _combined(a, s, b, t):
    """s a + t b of two partials tuples."""
    return (
        a[0] * s + b[0] * t,
        a[1] * s + b[1] * t,
        a[2] * s + b[2] * t,
        a[3] * s + b[3] * t,
        a[4] * s + b[4] * t,
        a[5] * s + b[5] * t,
        a[6] * s + b[6] * t,
    )


def _is_dual(x):
    return isinstance(x, DualType)


def _is_number(x):
    return isinstance(x, (types.Float, types.Integer))


def _unary(func: Any, derivative: Any) -> None:
    """Overload ``func`` for a dual: value func(v), partials derivative(v, func(v)) g."""

    @overload(func)
    def _impl(a):
        if _is_dual(a):

            def apply(a):
                y = func(a.v)
                return make_dual(y, _scaled(a.g, derivative(a.v, y)))

            return apply
        return None


_unary(math.exp, njit(inline="always")(lambda x, y: y))
_unary(math.log, njit(inline="always")(lambda x, y: 1.0 / x))
_unary(math.sqrt, njit(inline="always")(lambda x, y: 0.5 / y if y > 0.0 else 0.0))
_unary(math.cos, njit(inline="always")(lambda x, y: -math.sin(x)))
_unary(math.tanh, njit(inline="always")(lambda x, y: 1.0 - y * y))
_unary(math.asinh, njit(inline="always")(lambda x, y: 1.0 / math.sqrt(1.0 + x * x)))


@overload(operator.neg)
def _neg(a):
    if _is_dual(a):
        return lambda a: make_dual(-a.v, _scaled(a.g, -1.0))
    return None


@overload(operator.add)
@overload(operator.iadd)
def _add(a, b):
    if _is_dual(a) and _is_dual(b):
        return lambda a, b: make_dual(a.v + b.v, _combined(a.g, 1.0, b.g, 1.0))
    if _is_dual(a) and _is_number(b):
        return lambda a, b: make_dual(a.v + b, a.g)
    if _is_number(a) and _is_dual(b):
        return lambda a, b: make_dual(a + b.v, b.g)
    return None


@overload(operator.sub)
@overload(operator.isub)
def _sub(a, b):
    if _is_dual(a) and _is_dual(b):
        return lambda a, b: make_dual(a.v - b.v, _combined(a.g, 1.0, b.g, -1.0))
    if _is_dual(a) and _is_number(b):
        return lambda a, b: make_dual(a.v - b, a.g)
    if _is_number(a) and _is_dual(b):
        return lambda a, b: make_dual(a - b.v, _scaled(b.g, -1.0))
    return None


@overload(operator.mul)
@overload(operator.imul)
def _mul(a, b):
    if _is_dual(a) and _is_dual(b):
        return lambda a, b: make_dual(a.v * b.v, _combined(a.g, b.v, b.g, a.v))
    if _is_dual(a) and _is_number(b):
        return lambda a, b: make_dual(a.v * b, _scaled(a.g, b))
    if _is_number(a) and _is_dual(b):
        return lambda a, b: make_dual(a * b.v, _scaled(b.g, a))
    return None


@overload(operator.truediv)
@overload(operator.itruediv)
def _truediv(a, b):
    if _is_dual(a) and _is_dual(b):

        def both(a, b):
            q = a.v / b.v
            return make_dual(q, _combined(a.g, 1.0 / b.v, b.g, -q / b.v))

        return both
    if _is_dual(a) and _is_number(b):
        return lambda a, b: make_dual(a.v / b, _scaled(a.g, 1.0 / b))
    if _is_number(a) and _is_dual(b):

        def denominator(a, b):
            q = a / b.v
            return make_dual(q, _scaled(b.g, -q / b.v))

        return denominator
    return None


@overload(operator.pow)
def _pow(a, b):
    if _is_dual(a) and _is_number(b):

        def power(a, b):
            y = a.v**b
            slope = b * a.v ** (b - 1.0) if a.v != 0.0 else 0.0
            return make_dual(y, _scaled(a.g, slope))

        return power
    if _is_dual(a) and _is_dual(b):

        def general(a, b):
            y = a.v**b.v
            slope = b.v * a.v ** (b.v - 1.0) if a.v != 0.0 else 0.0
            log_slope = y * math.log(a.v) if a.v > 0.0 else 0.0
            return make_dual(y, _combined(a.g, slope, b.g, log_slope))

        return general
    return None


def _comparison(op: Any) -> None:
    """Overload comparison ``op``: duals compare by value."""

    @overload(op)
    def _impl(a, b):
        if _is_dual(a) and _is_dual(b):
            return lambda a, b: op(a.v, b.v)
        if _is_dual(a) and _is_number(b):
            return lambda a, b: op(a.v, b)
        if _is_number(a) and _is_dual(b):
            return lambda a, b: op(a, b.v)
        return None


for _op in (operator.gt, operator.ge, operator.lt, operator.le):
    _comparison(_op)


@overload(abs)
def _abs(a):
    if _is_dual(a):
        return lambda a: a if a.v >= 0.0 else make_dual(-a.v, _scaled(a.g, -1.0))
    return None


@overload(max)
def _max(a, b):
    if _is_dual(a) or _is_dual(b):
        return lambda a, b: b if b > a else a  # the first of equal arguments, as Python's max
    return None


@overload(min)
def _min(a, b):
    if _is_dual(a) or _is_dual(b):
        return lambda a, b: b if b < a else a
    return None


@overload(math.hypot)
def _hypot(a, b):
    if _is_dual(a) and _is_dual(b):

        def both(a, b):
            h = math.hypot(a.v, b.v)
            if h == 0.0:
                return make_dual(h, _scaled(a.g, 0.0))
            return make_dual(h, _combined(a.g, a.v / h, b.g, b.v / h))

        return both
    if _is_dual(a) and _is_number(b):
        return lambda a, b: math.hypot(a, make_dual(b, _scaled(a.g, 0.0)))
    if _is_number(a) and _is_dual(b):
        return lambda a, b: math.hypot(make_dual(a, _scaled(b.g, 0.0)), b)
    return None


@overload(math.atan2)
def _atan2(a, b):
    if _is_dual(a) and _is_dual(b):

        def both(a, b):
            y = math.atan2(a.v, b.v)
            norm2 = a.v * a.v + b.v * b.v
            if norm2 == 0.0:
                return make_dual(y, _scaled(a.g, 0.0))
            return make_dual(y, _combined(a.g, b.v / norm2, b.g, -a.v / norm2))

        return both
    return None
