"""Physical quantities: ``"8um"``, ``"1kPa"``, ``"15mPa*s"`` or a bare number, parsed into an option's unit,
and :class:`ParameterError`, the one-line error every impossible input raises.
"""

from __future__ import annotations

from functools import lru_cache


class ParameterError(ValueError):
    """An impossible input. ``parameter`` is the user-facing name, the message says the allowed range."""

    def __init__(self, parameter: str, message: str):
        self.parameter = parameter
        super().__init__(f"{parameter}: {message}")


@lru_cache(maxsize=1)
def _unit_registry():
    import pint

    return pint.UnitRegistry()


def parse_quantity(value: float | str, unit: str, parameter: str) -> tuple[float, bool]:
    """Parse ``value`` as a number (dimensionless) or a physical quantity convertible to ``unit``.

    Returns ``(magnitude, is_physical)``; a physical value is returned in the SI ``unit``.
    ``"8um"`` -> ``(8e-6, True)`` for ``unit="m"``; ``"2.5"`` or ``2.5`` -> ``(2.5, False)``.
    """
    if isinstance(value, int | float):
        return float(value), False
    text = str(value).strip()
    try:
        return float(text), False
    except ValueError:
        pass
    import pint

    ureg = _unit_registry()
    try:
        quantity = ureg.Quantity(text)
        return float(quantity.to(unit).magnitude), True
    except (pint.errors.PintError, ValueError, AttributeError, TypeError) as error:
        raise ParameterError(
            parameter, f"cannot read {text!r} as a number or a quantity in {unit} ({error})"
        ) from None
