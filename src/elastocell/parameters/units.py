"""Physical quantities: ``"8um"``, ``"1kPa"``, ``"15mPa*s"`` or a bare number, parsed into an option's unit,
and :class:`ParameterError`, the one-line error every impossible input raises.

One rule for bare numbers: a bare number is in its quantity's documented unit, :data:`BARE_UNITS` (a length in
um, a viscosity in mPa*s, a flow rate in uL/s, a modulus or stress in Pa, a rate in 1/s, an angle in degrees, a
temperature in degC, ...).
The one
exception is a dimensionless scale: ``parse_quantity(..., scale="units of R")`` returns a bare number as it is
(the cell radius and Young's modulus of a simulation, whose default 1 gives results in units of R and E_c).

A string is checked by a small tokeniser before anything reaches pint: a number (decimal or scientific, finite)
optionally followed by a unit expression of at most :data:`MAX_LENGTH` characters made of known unit names
(:func:`unit_names`), ``*``, ``.`` or a space (product), ``/``, ``^n`` or ``**n`` with ``|n| <= 4``, and one
level of parentheses; a temperature is a number and one of degC, °C, celsius, K, kelvin (:func:`parse_temperature`:
``"23degC"``, ``"23°C"``, ``"296.15K"`` and ``23`` are the same). Anything else is refused with one line naming the
parameter and the expected unit, so
every string is answered in microseconds (pint itself evaluates integer powers exactly: ``9**9**9`` would
never return).
"""

from __future__ import annotations

import math
import numbers
import re
from dataclasses import dataclass
from functools import lru_cache

MAX_LENGTH = 64
MAX_EXPONENT = 4
# the dimensionless scales of a simulated cell (a bare radius or Young's modulus is in these)
RADIUS_SCALE = "units of R"
MODULUS_SCALE = "units of E_c"


class ParameterError(ValueError):
    """An impossible input. ``parameter`` is the user-facing name, the message says the allowed range."""

    def __init__(self, parameter: str, message: str):
        self.parameter = parameter
        super().__init__(f"{parameter}: {message}")


@dataclass(frozen=True)
class Quantity:
    """A kind of physical quantity: its SI unit, what it is called, an example, and the unit of a bare number."""

    si: str
    noun: str
    example: str
    bare: str


# SI unit (as the callers spell it) -> the kind of quantity; ``bare`` is the one unit of a bare number
BARE_UNITS: dict[str, Quantity] = {q.si: q for q in (
    Quantity("m", "a length", "8um", "um"),
    Quantity("Pa", "a modulus or stress", "1kPa", "Pa"),
    Quantity("Pa*s", "a viscosity", "15mPa*s", "mPa*s"),
    Quantity("1/s", "a rate", "1000/s", "1/s"),
    Quantity("m^3/s", "a flow rate", "0.04uL/s", "uL/s"),
    Quantity("Pa/m", "a pressure gradient", "1e5Pa/m", "Pa/m"),
    Quantity("N/m", "a spring constant", "0.05N/m", "N/m"),
    Quantity("m/V", "a sensitivity", "50nm/V", "nm/V"),
    Quantity("deg", "an angle", "20deg", "deg"),
    Quantity("degC", "a temperature", "23degC", "degC"),
)}

_PREFIXES = ("", "p", "n", "u", "m", "c", "d", "k", "M", "G")
_SYMBOLS = ("m", "s", "Pa", "N", "V", "L", "l", "g", "Hz", "rad", "P")
_WORD_PREFIXES = ("", "pico", "nano", "micro", "milli", "centi", "deci", "kilo", "mega", "giga")
_WORDS = ("meter", "metre", "second", "pascal", "newton", "volt", "liter", "litre", "gram", "radian", "poise")
_TEMPERATURES = {"degC": "degC", "\u00b0C": "degC", "celsius": "degC", "K": "kelvin",
                 "kelvin": "kelvin"}
"""Temperature units (no prefixes) and pint's spelling of each."""


@lru_cache(maxsize=1)
def unit_names() -> frozenset[str]:
    """Every unit name a quantity may use: SI prefixes p n u (or µ) m c d k M G on m s Pa N V L l g Hz rad P
    (poise), the same spelled out (micrometre(s), millipascal, ...), hertz, min, minute(s), h, hour(s), deg,
    degree(s), and the temperatures degC, °C, celsius, K, kelvin."""
    names = {p + s for p in _PREFIXES for s in _SYMBOLS}
    names |= {p + w + plural for p in _WORD_PREFIXES for w in _WORDS for plural in ("", "s")}
    names |= {p + "hertz" for p in _WORD_PREFIXES}
    names |= {"min", "minute", "minutes", "h", "hour", "hours", "deg", "degree", "degrees"}
    names |= set(_TEMPERATURES)
    return frozenset(names)


_NUMBER = re.compile(r"[+-]?(?:[0-9]+\.?[0-9]*|\.[0-9]+)(?:[eE][+-]?[0-9]+)?")
_TOKEN = re.compile(r"\s*(?:(?P<name>[A-Za-z\u00b5\u03bc\u00b0]+)|(?P<power>(?:\^|\*\*)\s*(?P<exponent>[+-]?[0-9]+))"
                    r"|(?P<op>[*/.])|(?P<open>\()|(?P<close>\)))")


class _Refused(Exception):
    """The reason a string is not a quantity (becomes the parenthesis of the ParameterError)."""


def _unit_expression(text: str) -> str:
    """The canonical pint spelling of a unit expression (``"mPa.s"`` -> ``"mPa*s"``); raises _Refused."""
    out: list[str] = []
    position, depth = 0, 0
    operand = False  # the last token ends an operand (a name or a closing parenthesis)
    powered = False  # that operand already has an exponent
    while position < len(text):
        match = _TOKEN.match(text, position)
        if match is None or match.end() == position:
            if text[position:].strip() == "":
                break
            raise _Refused(f"unexpected {text[position:].strip()[:12]!r}")
        position = match.end()
        if match["name"] is not None:
            name = match["name"].replace("\u00b5", "u").replace("\u03bc", "u")
            if name not in unit_names():
                raise _Refused(f"unknown unit {match['name']!r}")
            name = _TEMPERATURES.get(name, name)
            out.append(("*" if operand else "") + name)
            operand, powered = True, False
        elif match["power"] is not None:
            exponent = int(match["exponent"])
            if not operand or powered:
                raise _Refused("an exponent needs a unit before it")
            if abs(exponent) > MAX_EXPONENT:
                raise _Refused(f"exponents are at most {MAX_EXPONENT} in size")
            out.append(f"**{exponent}")
            powered = True
        elif match["op"] is not None:
            if not operand and out:
                raise _Refused(f"{match['op']!r} needs a unit before it")
            if not out and match["op"] == ".":
                raise _Refused("a unit cannot start with '.'")
            out.append("/" if match["op"] == "/" else "*")
            operand = False
        elif match["open"] is not None:
            if depth:
                raise _Refused("parentheses are at most one level deep")
            out.append(("*" if operand else "") + "(")
            depth, operand = 1, False
        else:
            if not depth or not operand:
                raise _Refused("unbalanced parentheses")
            out.append(")")
            depth, operand, powered = 0, True, False
    if depth:
        raise _Refused("unbalanced parentheses")
    if out and not operand:
        raise _Refused("the unit ends in an operator")
    expression = "".join(out)
    if expression.startswith("*"):
        expression = expression[1:]
    return "1" + expression if expression.startswith("/") else expression


@lru_cache(maxsize=1)
def _unit_registry():
    import pint

    return pint.UnitRegistry()


@lru_cache(maxsize=256)
def _factor(expression: str, unit: str) -> tuple[object, str | None]:
    """The pint unit of ``expression``, or why it is not convertible to ``unit``."""
    import pint

    registry = _unit_registry()
    try:
        units = registry.parse_units(expression)
        registry.Quantity(1.0, units).to(unit)
    except pint.errors.DimensionalityError:
        return None, f"{expression} is not {describe_kind(unit)}"
    except (pint.errors.PintError, ValueError, AttributeError, TypeError) as error:
        return None, f"{expression}: {error}"
    return units, None


def describe_kind(unit: str) -> str:
    """``"a length"`` for ``"m"``; the SI unit itself for a unit :data:`BARE_UNITS` does not list."""
    kind = BARE_UNITS.get(unit)
    return kind.noun if kind is not None else f"a quantity in {unit}"


def expected(unit: str, scale: str | None = None) -> str:
    """``"a length like 8um or a bare number in um"``: what a parameter in ``unit`` accepts."""
    kind = BARE_UNITS[unit]
    return f"{kind.noun} like {kind.example} or a bare number in {scale or kind.bare}"


def _shown(value) -> str:
    text = str(value)
    if len(text) > 40:
        return f"{text[:24] + '...'!r} ({len(text)} characters)"
    return repr(text)


def parse_quantity(value: float | str, unit: str, parameter: str, scale: str | None = None) -> tuple[float, bool]:
    """Parse ``value`` as a quantity of the kind whose SI unit is ``unit`` (a key of :data:`BARE_UNITS`).

    Returns ``(magnitude, is_physical)``: a quantity with a unit (``"8um"``) and a bare number (``8``, ``"8"``)
    are returned in ``unit`` (``(8e-6, True)`` for ``unit="m"``: a bare length is in um). With ``scale`` (the
    words for it, e.g. ``"units of R"``) a bare number is dimensionless instead: ``"2.5"`` -> ``(2.5, False)``.
    Anything else (no number, an unknown unit, another dimension, nan, inf, more than ``MAX_LENGTH``
    characters) raises one :class:`ParameterError` naming ``parameter`` and what it expects.
    """
    kind = BARE_UNITS.get(unit)
    if kind is None:
        raise ValueError(f"parse_quantity: no documented bare unit for {unit!r} (add it to BARE_UNITS)")

    def refuse(reason: str | None = None):
        return ParameterError(parameter, f"expected {expected(unit, scale)}, got {_shown(value)}"
                              + (f" ({reason})" if reason else ""))

    if isinstance(value, numbers.Real) and not isinstance(value, bool):
        try:
            number = float(value)
        except (OverflowError, ValueError):
            raise refuse("not a finite number") from None
        expression = ""
    elif isinstance(value, str):
        text = value.strip()
        if len(text) > MAX_LENGTH:
            raise refuse(f"longer than {MAX_LENGTH} characters")
        match = _NUMBER.match(text)
        if match is None:
            non_finite = re.match(r"[+-]?(nan|inf)", text, re.IGNORECASE)
            raise refuse("not a finite number" if non_finite else "no number first")
        number = float(match.group())
        try:
            expression = _unit_expression(text[match.end():])
        except _Refused as reason:
            raise refuse(str(reason)) from None
    else:
        raise refuse(f"a {type(value).__name__}")
    if not math.isfinite(number):
        raise refuse("not a finite number")
    if not expression:
        if scale is not None:
            return number, False
        expression = kind.bare  # a constant of this module: pint reads it as it is
    units, problem = _factor(expression, unit)
    if units is None:
        raise refuse(problem)
    magnitude = float(_unit_registry().Quantity(number, units).to(unit).magnitude)
    if not math.isfinite(magnitude):
        raise refuse(f"not finite in {unit}")
    return magnitude, True


def parse_temperature(value, parameter: str = "temperature") -> float | None:
    """A temperature in degC (None stays None): ``"23degC"``, ``"23°C"``, ``"296.15K"`` or a bare number, which is in
    degC (:data:`BARE_UNITS`); refused in one line naming ``parameter`` below absolute zero or when not a
    temperature."""
    if value is None:
        return None
    celsius, _ = parse_quantity(value, "degC", parameter)
    if celsius < -273.15:
        raise ParameterError(parameter, f"must be above absolute zero (-273.15 degC, 0 K), got {_shown(value)}")
    return celsius
