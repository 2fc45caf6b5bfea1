"""Deck parameters for any registered material, plugins included, so that a problem that applies
to every material (``rigid-rotation``) and ``peridyn verify --material NAME`` can build it.

The elastic constants are the verify problems' own (rho = 1000 kg/m^3, K = 1 GPa, G = 0.45 K: 3K
!= 5G, so a dilatation term counts). A parameter the material requires beyond them takes the
value in :data:`REQUIRED` (chosen so that the model stays elastic at the problems' strains of 1e-3
or less: yield stresses of 1000 K); a required parameter not listed there makes the material
not applicable, with that parameter named."""
from __future__ import annotations

from typing import Any

from ..plugins.manager import get_registry

RHO, K, G = 1000.0, 1.0e9, 0.45e9
ELASTIC = {"Density": RHO, "Bulk Modulus": K, "Shear Modulus": G}

#: values of required parameters beyond the elastic ones; "horizon" stands for the block's horizon
REQUIRED: dict[str, Any] = {
    "Yield Stress": 1.0e12, "Hardening Modulus": 0.0, "lambda_i": 0.5, "tau b": 1.0e-3,
    "Hourglass Coefficient": 0.02, "Actual Horizon": "horizon",
    "Hardening Characteristic Strain": 0.01, "Hardening Exponent": 0.2,
    "Strain Hardening Exponent": 0.1, "Rate Hardening Exponent": 0.01, "Reference Strain Rate": 1.0,
    "Reference Strain 0": 0.01, "Reference Strain 1": 1.0,
    "Hardening Rule": "Power-law", "Hardening Parameters": {"Yield Stress": 1.0e12, "Hardening Characteristic Strain": 0.01, "Hardening Exponent": 0.2},
    "Stress Law": "peridyn.materials.correspondence.laws:neo_hookean", "Law Parameters": [G, K - 2.0 * G / 3.0],
    "Permeability": 1.0e-12, "Fluid density": 1.0e-9, "Fluid dynamic viscosity": 1.0e-8, "Fluid compressibility": 1.0e-9,
    "Fluid Reynolds viscosity temperature effect": 0.0, "Fluid linear thermal expansion": 0.0,
    "Permeability curve inflection damage": 0.1, "Max permeability": 1.0, "Permeability alpha": 0.25,
}


def _aliases(cls: type) -> tuple[set[str], set[str]]:
    """(every deck key, the required ones) of a material class's ``Params``."""
    fields = cls.Params.model_fields  # type: ignore[attr-defined]
    names = {f.alias or k for k, f in fields.items()}
    return names, {f.alias or k for k, f in fields.items() if f.is_required()}


def material_names() -> list[str]:
    """Every registered material, in the registry's order (built-ins first)."""
    return get_registry().names("material")


def parameters(name: str, horizon: float) -> dict[str, Any] | str:
    """The deck entry (``Material Model`` included) of material ``name`` with a block horizon of
    ``horizon`` (m), or why it cannot be built here (one line: not mechanical, a required
    parameter with no value here, a class that does not load)."""
    try:
        cls = get_registry().get("material", name)
    except Exception as exc:  # noqa: BLE001 - reported as the material's reason
        return f"does not load: {exc}"
    keys, required = _aliases(cls)
    if "Density" not in keys:
        return "not a mechanical model (no Density)"
    out: dict[str, Any] = {"Material Model": name}
    out.update({k: v for k, v in ELASTIC.items() if k in keys})
    if "Shear Modulus" not in keys:  # bond-based: K alone
        out.pop("Shear Modulus", None)
    missing = []
    for key in sorted(required - set(out)):
        if key in REQUIRED:
            value = REQUIRED[key]
            out[key] = horizon if value == "horizon" else value
        else:
            missing.append(key)
    if missing:
        return f"needs {', '.join(repr(m) for m in missing)}, which the verify problems have no value for"
    for key in ("Law Parameters",):  # optional ones that go with a required one
        if key in keys and key not in out and "Stress Law" in out:
            out[key] = REQUIRED[key]
    return out
