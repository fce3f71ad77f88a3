"""The suspending medium of a flow: Newtonian or shear-thinning (power law), with the MC-PBS presets of RT-DC.

A power-law liquid has the viscosity eta(gdot) = K gdot^(n - 1) (consistency K in Pa s^n, flow index n; n < 1
shear-thinning). The methylcellulose buffers of real-time deformability cytometry (MC-PBS) follow it over the
shear rates of the channel, with temperature-dependent K and n (Buyukurganci et al. 2022, as dclab implements it
in ``dclab.features.emodulus.viscosity.get_viscosity_mc_pbs_buyukurganci_2022``):

    K = a exp(lambda / T),   n = alpha T + beta,   T in kelvin,  alpha = 0.00223 1/K,  lambda = 3379.7 K,

with (a [Pa s^n], beta) = (2.30e-6, -0.0056) for 0.49 % MC-PBS, (5.70e-6, -0.0744) for 0.59 % and
(16.52e-6, -0.1455) for 0.83 %; the fit covers 22 - 37 degC.

The lattice side (a per-node relaxation time from the local strain rate) is :mod:`elastocell.lattice.rheology`.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass

from elastocell.parameters.units import ParameterError

MC_PBS_ALPHA = 0.00223
"""d n / d T of MC-PBS (1/K), Buyukurganci et al. 2022."""

MC_PBS_LAMBDA = 3379.7
"""Activation temperature of the consistency K of MC-PBS (K), Buyukurganci et al. 2022."""

MC_PBS = {"0.49%MC-PBS": (2.30e-6, -0.0056), "0.59%MC-PBS": (5.70e-6, -0.0744), "0.83%MC-PBS": (16.52e-6, -0.1455)}
"""(a in Pa s^n, beta) of each MC-PBS preset: K = a exp(lambda/T), n = alpha T + beta (dclab's
``get_viscosity_mc_pbs_buyukurganci_2022``, with its 0.49 % value a = 2.30e-6 of Reichel et al. 2023)."""

MC_PBS_TEMPERATURES = (22.0, 37.0)
"""Temperature range (degC) of the MC-PBS fit; outside it a preset is extrapolated (one warning)."""

MEDIA = ("newtonian", *MC_PBS)
"""Names a ``medium`` option accepts (besides ``power-law`` with its own K and n)."""

DEFAULT_TEMPERATURE = 23.0
"""Temperature of the RT-DC standard configuration (degC)."""

KOZICKI_SQUARE = (0.2121, 0.6771)
"""Geometric coefficients (a, b) of a square duct in Kozicki et al.'s generalised Reynolds number (1966): the
mean wall shear rate of a power-law liquid is gdot_w = (8 V / D_h) (b + a/n) with V = Q/W^2, D_h = W (exact for
n = 1). dclab's ``shear_rate_square_channel`` writes 0.6671 for b."""


@dataclass(frozen=True)
class Medium:
    """A suspending medium: ``model`` "newtonian" or "power-law"; for a power law the flow index n and the
    consistency K (Pa s^n) with eta = K gdot^(n-1); ``name`` the preset (or the model) and ``temperature``
    (degC, None when it does not enter)."""

    name: str = "newtonian"
    model: str = "newtonian"
    flow_index: float = 1.0
    consistency: float | None = None
    temperature: float | None = None

    @property
    def is_newtonian(self) -> bool:
        return self.model == "newtonian"

    def viscosity(self, shear_rate):
        """eta(gdot) in Pa s for shear rates in 1/s (a power law; refused for a Newtonian medium)."""
        if self.is_newtonian or self.consistency is None:
            raise ValueError("a Newtonian medium has no shear-rate law here: its viscosity is the flow's own")
        return self.consistency * shear_rate ** (self.flow_index - 1.0)

    def as_dict(self) -> dict:
        return {"medium": self.name, "medium_model": self.model, "flow_index": self.flow_index,
                "consistency_pa_s_n": self.consistency, "temperature_c": self.temperature}


MC_PBS_ALIASES = {"cellcarrier": "0.49%MC-PBS", "0.5%mc-pbs": "0.49%MC-PBS", "0.50%mc-pbs": "0.49%MC-PBS",
                  "cellcarrierb": "0.59%MC-PBS", "0.6%mc-pbs": "0.59%MC-PBS", "0.60%mc-pbs": "0.59%MC-PBS",
                  "0.8%mc-pbs": "0.83%MC-PBS", "0.80%mc-pbs": "0.83%MC-PBS"}
"""dclab's other names of the MC-PBS buffers (``dclab.features.emodulus.viscosity.ALIAS_MEDIA``: the commercial
CellCarrier is 0.49 %, CellCarrier B 0.59 %), case and blanks removed, and the preset each names."""


def canonical_name(name: str) -> str:
    """The preset key of a medium name: case and blanks ignored ("0.59% MC-PBS" -> "0.59%MC-PBS"), dclab's other
    names of the buffers too (:data:`MC_PBS_ALIASES`: "CellCarrier B" -> "0.59%MC-PBS")."""
    key = str(name).replace(" ", "").lower()
    for preset in (*MEDIA, "power-law"):
        if preset.lower() == key:
            return preset
    if key in MC_PBS_ALIASES:
        return MC_PBS_ALIASES[key]
    raise ParameterError("medium", f"unknown medium {name!r}: use one of {', '.join(MEDIA)} (or dclab's names "
                                   "CellCarrier, CellCarrier B) or power-law")


def mc_pbs(name: str, temperature: float = DEFAULT_TEMPERATURE) -> Medium:
    """The MC-PBS preset ``name`` ("0.49%MC-PBS", "0.59%MC-PBS", "0.83%MC-PBS") at ``temperature`` degC."""
    key = canonical_name(name)
    if key not in MC_PBS:
        raise ParameterError("medium", f"{name!r} is not an MC-PBS preset ({', '.join(MC_PBS)})")
    t = float(temperature)
    if not (math.isfinite(t) and 0.0 < t < 100.0):
        raise ParameterError("temperature", f"must be in (0, 100) degC (liquid buffer), got {temperature}")
    lo, hi = MC_PBS_TEMPERATURES
    if not lo <= t <= hi:
        warnings.warn(f"temperature {t:g} degC is outside the MC-PBS fit ({lo:g}-{hi:g} degC): K and n are "
                      "extrapolated", stacklevel=2)
    a, beta = MC_PBS[key]
    kelvin = t + 273.15
    return Medium(name=key, model="power-law", flow_index=MC_PBS_ALPHA * kelvin + beta,
                  consistency=a * math.exp(MC_PBS_LAMBDA / kelvin), temperature=t)


def power_law(flow_index: float, consistency: float | None = None) -> Medium:
    """A power-law medium of flow index n in (0, 2] (consistency K in Pa s^n, optional: lattice runs need only n)."""
    n = float(flow_index)
    if not (math.isfinite(n) and 0.1 <= n <= 2.0):
        raise ParameterError("flow_index", f"must be in [0.1, 2] (power-law index n), got {flow_index}")
    if consistency is not None and not (math.isfinite(consistency) and consistency > 0):
        raise ParameterError("consistency", f"must be > 0 (Pa s^n), got {consistency}")
    return Medium(name="power-law", model="power-law", flow_index=n, consistency=consistency)


def medium(name: str | Medium | None = "newtonian", temperature: float | None = None,
           flow_index: float | None = None) -> Medium:
    """A :class:`Medium` from a name ("newtonian", an MC-PBS preset, or "power-law" with ``flow_index``)."""
    if isinstance(name, Medium):
        return name
    key = canonical_name("newtonian" if name is None else name)
    if key == "newtonian":
        if flow_index is not None:
            raise ParameterError("flow_index", "a Newtonian medium has n = 1: give --medium power-law")
        return Medium(temperature=None if temperature is None else float(temperature))
    if key == "power-law":
        if flow_index is None:
            raise ParameterError("flow_index", "the power-law medium needs its flow index n")
        return power_law(flow_index)
    if flow_index is not None:
        raise ParameterError("flow_index", f"the preset {key} sets n itself (n = alpha T + beta)")
    return mc_pbs(key, DEFAULT_TEMPERATURE if temperature is None else temperature)


def kozicki_wall_shear_rate(flow_rate: float, width: float, flow_index: float) -> float:
    """Mean wall shear rate (1/s) of a power-law liquid at flow rate Q (m^3/s) through a square duct of width W (m):
    (8 Q / W^3) (b + a/n), :data:`KOZICKI_SQUARE` (Kozicki et al. 1966; exact for n = 1)."""
    a, b = KOZICKI_SQUARE
    return 8.0 * flow_rate / width**3 * (b + a / flow_index)
